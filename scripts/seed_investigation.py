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
from eodarm.analysis.crossval import cross_validate
from eodarm.analysis.fit import FitWarning, fit
from eodarm.analysis.workflow import investigate
from eodarm.data import datasets
from seed_verdicts import best_candidate, judged, refusal

ROOT = Path(__file__).resolve().parent.parent
BODIES = [f"actuator_compliance@M{i}" for i in (1, 2, 3)]
MOUNTS = [f"mount_compliance@M{i}" for i in (1, 2, 3)]
BEST = BODIES + MOUNTS


def _load_effects() -> None:
    runpy.run_path(str(ROOT / "examples" / "thresholds.py"))


def models() -> list[tuple[str, list[str]]]:
    ms: list[tuple[str, list[str]]] = [
        ("500 N/mm springs (nothing fitted)", []),
        ("bodies + mounts (§4's best)", BEST),
    ]
    for k in (1, 2, 3):
        ms.append((f"+ actuator_play@M{k}:taken_up", [*BEST, f"actuator_play@M{k}:taken_up"]))
    ms.append(
        (
            "+ actuator_play@M1–M3:taken_up",
            [*BEST, *(f"actuator_play@M{k}:taken_up" for k in (1, 2, 3))],
        )
    )
    for k in (1, 2, 3):
        ms.append((f"+ joint_clearance@O{k}:taken_up", [*BEST, f"joint_clearance@O{k}:taken_up"]))
    ms.append(
        (
            "+ actuator_friction@M1–M3",
            [*BEST, *(f"actuator_friction@M{k}" for k in (1, 2, 3))],
        )
    )
    for k in (1, 2, 3):
        ms.append((f"+ joint_friction@O{k}", [*BEST, f"joint_friction@O{k}"]))
    for k in (1, 2, 3):
        ms.append((f"+ mount_preload@M{k} (user)", [*BEST, f"mount_preload@M{k}"]))
    ms.append(
        ("+ mount_preload@M1–M3 (user)", [*BEST, *(f"mount_preload@M{k}" for k in (1, 2, 3))])
    )
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


def _estimate(a: dict) -> str:
    """``spec=estimate±stderr unit``, or the estimate marked at its bound or not determined
    (no standard error printed as if known)."""
    value = f"{a['spec']}={a['estimate']:.3g} {a['unit']}"
    if a["at_bound"]:
        return f"{value} (at its bound)"
    if a["undetermined"]:
        return f"{value} (not determined: {a['undetermined']})"
    return f"{a['spec']}={a['estimate']:.3g}±{a['stderr']:.2g} {a['unit']}"


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
        loose = dict(r.undetermined())
        added = [
            {
                "spec": r.slots[i].spec,
                "estimate": r.estimate(i),
                "stderr": r.stderr(i),
                "unit": r.slots[i].kind.unit,
                "at_bound": bool(r.at_bound[i]),
                "undetermined": loose.get(i),
            }
            for i in range(len(r.slots))
            if r.slots[i].spec not in BEST
        ]
        extra = [_estimate(a) for a in added]
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
                "added": added,
            }
        )
    return {"rows": rows, "line": line}


def table(rows: list[dict[str, Any]]) -> str:
    out = [
        "| model | fitted | sag RMS in-sample (mm) | sag RMS held out (mm) | χ²/dof "
        "| added effect(s), estimate ± stderr |",
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


def section(arm: eodarm.Arm | None = None, meas: eodarm.Measurements | None = None) -> str:
    """§6 of docs/seed-reproduction.md: the table of both runs and what they say."""
    _load_effects()
    ds = datasets.load("seed2022")
    arm = arm or ds.arm
    meas = meas or ds.measurements
    full = run(True)["rows"]
    noang = run(False)["rows"]
    by = {r["label"]: r for r in full}
    line = full[0]
    best = by["bodies + mounts (§4's best)"]
    phys = [r for r in full[1:] if r["n"] > 0]
    top = min(phys, key=lambda r: (round(r["cv"], 3), r["n"]))
    beats_line = [r["label"] for r in phys if r["cv"] < line["cv"]]
    below_1 = [r["label"] for r in phys if r["cv"] < 1.0]
    gaps = [r for r in full if "taken_up" in r["label"]]
    thr = [r for r in full if "preload" in r["label"] or "friction" in r["label"]]
    best_na = next(r for r in noang if r["label"] == best["label"])
    import warnings as _w

    with _w.catch_warnings():
        _w.simplefilter("ignore", FitWarning)
        d = eodarm.diagnose(arm, meas, model=BEST)
        inv = investigate(arm, meas)  # what `eodarm report --effects ...` runs
    be = ", ".join(s.key for s in (d.best_effort or [])) or "the model as it is"
    acc = d.acceptance
    be_cv = acc.cv["rms"]["dy_mm"] if acc is not None and acc.cv is not None else float("nan")
    undetermined = sorted({u.split(" (")[0] for r in full[1:] for u in r["undetermined"]})
    intercepts = []
    y = meas.values[:, meas.channels.index("dy_mm")]
    cfg = np.asarray(meas.config)
    for c in meas.configs:
        sel = cfg == c
        _b, a = np.polyfit(meas.mass_kg[sel], -y[sel], 1)
        intercepts.append(a)

    sol = eodarm.solve(arm, meas.alpha_deg, meas.mass_kg)
    sol0 = eodarm.solve(arm, meas.alpha_deg, np.zeros_like(meas.mass_kg))
    f, f0 = sol["force_n"], sol0["force_n"]
    n_rev = int((np.sign(f) != np.sign(f0)).sum())
    f0_min = float(np.abs(f0).min())
    r1, r0 = sol["reaction_n"], sol0["reaction_n"]
    cosang = (r1 * r0).sum(-1) / np.linalg.norm(r1, axis=-1) / np.linalg.norm(r0, axis=-1)
    turn = np.degrees(np.arccos(np.clip(cosang, -1, 1))).max(0)
    pre = [r for r in thr if "friction" not in r["label"]]
    singles = [r for r in pre if "M1–M3" not in r["label"]]
    max_z = max(abs(a["estimate"]) / a["stderr"] for r in singles for a in r["added"])
    m3 = next(r for r in singles if r["label"].startswith("+ mount_preload@M3"))
    gain = [k for k in m3["per_config"] if m3["per_config"][k] < best["per_config"][k] - 0.005]
    better_line = [k for k in line["per_config"] if best["per_config"][k] < line["per_config"][k]]
    worse_line = [k for k in line["per_config"] if best["per_config"][k] >= line["per_config"][k]]
    act_fr = by["+ actuator_friction@M1–M3"]
    joint_fr = [r for r in full if r["label"].startswith("+ joint_friction@")]
    bf = d.best_effort_fit
    be_vals = (
        ", ".join(
            f"{s.key} {bf.estimate(i):.2g} {s.kind.unit}"
            for i, s in enumerate(bf.slots)
            if s.key not in BEST
        )
        if bf is not None
        else ""
    )

    def name(r: dict[str, Any]) -> str:
        return r["label"][2:].replace(" (user)", "")

    def versus(rows: list[dict[str, Any]]) -> str:
        """How each model's held-out sag compares with §4's best."""
        worse = [r for r in rows if r["cv"] > best["cv"] + 5e-3]
        if len(worse) == len(rows):
            word = "every one of them makes the held-out sag *worse*"
        elif not worse:
            word = "none of them makes the held-out sag worse"
        else:
            word = f"{len(worse)} of {len(rows)} make the held-out sag *worse*"
        return (
            f"{word} ("
            + ", ".join(f"{name(r)} {r['cv']:.2f}" for r in rows)
            + f" mm against {best['cv']:.2f})"
        )

    w: list[str] = []
    w.append("## 6. Thresholds, taken-up gaps and a line through zero\n")
    w.append(
        "Generated by `scripts/seed_investigation.py` (which prints the same tables). The best "
        f"physics model of §4 predicts held-out sag to {best['cv']:.2f} mm RMS; a line through "
        f"zero, sag = b·payload with one slope b, fitted on four configurations and predicting "
        f"the fifth the same way, gets {line['cv']:.2f} mm. The residuals have a shape: a line "
        "through each configuration's three sags meets zero payload at "
        + ", ".join(f"{a:+.1f}" for a in intercepts)
        + " mm, below zero in "
        f"{sum(a < 0 for a in intercepts)} of {len(intercepts)} configurations, which is what a "
        "threshold does (the first newtons move less than the rest: friction, stiction, a "
        "preload). So the models below add to §4's best (bodies + mounts) the taken-up "
        "variants of play and clearance (model.md §4: the self-weight has already closed the "
        "gap, so only a reversal of a force shows), the two built-in frictions, each loaded "
        "once from the unloaded state and so a deadband (docs/model.md, load sequences and "
        "friction): `actuator_friction` in the actuator body, seen by its sensor, and "
        "`joint_friction`, a torque in the pin that holds the first newtons of the whole "
        "actuator's force change, body and mount, and two user-written threshold effects, "
        "`mount_preload` / `joint_preload` "
        "([examples/thresholds.py](../examples/thresholds.py): a mount or a joint that holds "
        "the first newtons of a force change, i.e. a constant relief δ against the "
        "deformation once the change passes a threshold, unseen by the motor sensors).\n"
    )
    w.append(
        "Every model is fitted to all 8 channels weighted by their stated σ, and held out by "
        "leaving one configuration out (`eodarm.cross_validate`, as `eodarm fit --cv config`). "
        "χ²/dof of the physics models is over every measured channel; the line's is over the "
        "sag alone (it predicts nothing else), so the two columns compare within a kind only.\n"
    )
    w.append(table(full))
    w.append("")
    w.append(
        "Held-out sag per configuration: line through zero "
        + ", ".join(f"{k} {v:.2f}" for k, v in line["per_config"].items())
        + " mm; bodies + mounts "
        + ", ".join(f"{k} {v:.2f}" for k, v in best["per_config"].items())
        + " mm.\n"
    )
    o1 = by["+ joint_clearance@O1:taken_up"]["added"][0]
    fr_move = act_fr["cv"] - best["cv"]
    w.append(
        "**What each mechanism does.** The taken-up gaps fit to zero (at their bound) in every "
        "place: "
        + ", ".join(f"{r['label'][2:]} held out {r['cv']:.2f} mm" for r in gaps)
        + f". With self-weight, no actuator force changes sign between the unloaded and any "
        f"loaded state ({n_rev} reversals in 45 actuator-states; the smallest unloaded force "
        f"is {f0_min:.0f} N), so a taken-up play cannot move at all: its sensitivity is zero "
        "and its standard error infinite. The joint forces turn by at most "
        + ", ".join(f"{t:.0f}°" for t in turn)
        + " at O1, O2, O3 between the two states, so a taken-up clearance could move the pins a "
        f"little, but the data want none (O1: {o1['estimate']:.2g} ± {o1['stderr']:.2g} "
        f"{o1['unit']}). The friction deadband in the actuator bodies "
        f"({act_fr['estimates']}) "
        + (
            f"leaves the held-out sag where it was ({act_fr['cv']:.2f} mm against {best['cv']:.2f})"
            if abs(fr_move) < 0.02
            else f"moves the held-out sag by {fr_move:+.2f} mm"
        )
        + ": it can only "
        "give back what the bodies themselves deform, and their own sensors say that is "
        "micrometres. The joint frictions reach the mounts too, and come out at "
        + ", ".join(r["estimates"] for r in joint_fr)
        + "; "
        + versus(joint_fr)
        + ". The preload reliefs in the mounts and joints come out at "
        + ", ".join(r["estimates"] for r in singles)
        + f", none more than {max_z:.1f} standard errors from zero (the standard errors "
        f"are scaled by √(χ²/dof), about {np.sqrt(best['chi2_per_dof']):.0f} here, as every "
        "fit's are where the model misses its data by more than their σ: docs/model.md §8; "
        "the Δχ² of the diagnosis below are on the stated σ), and "
        + versus(pre)
        + f". {name(m3)}, for instance, predicts configurations "
        + ", ".join(f"{k} {m3['per_config'][k]:.2f}" for k in gain)
        + " mm (without it "
        + ", ".join(f"{best['per_config'][k]:.2f}" for k in gain)
        + f") but c5 {m3['per_config']['c5']:.2f} mm (without it {best['per_config']['c5']:.2f}), "
        "the extreme pose whose prediction is an "
        "extrapolation. The intercepts are real in the sag, but the fit weighs the sag "
        "together with the three angles and the motor sensors, and a relief that lowers the "
        "light-payload sag also moves the angles.\n"
    )
    sig = [c for c in d.ranking if c.delta_chi2 > d.significance]
    lead = ", ".join(f"{c.slot.spec} (Δχ² {c.delta_chi2:.1f})" for c in d.ranking[:3])
    if sig:
        sig_txt = (
            f"; {len(sig)} of the {len(d.ranking)} lower χ² beyond the {d.significance:.1f} "
            "that the diagnosis requires of a real effect, and the rule refuses each of them "
            "alone: "
            + "; ".join(
                f"{c.slot.spec}: "
                + (refusal(a) if (a := judged(d, [c.slot.key])) is not None else "not judged")
                for c in sig
            )
        )
    else:
        sig_txt = ", " + best_candidate(
            d.ranking[0].slot.key, d.ranking[0].delta_chi2, d.significance, len(d.ranking), None
        )
    same = [s.key for s in inv.final_model] == BEST
    w.append(
        f"**The diagnosis with these effects** (`eodarm diagnose ... --add` the six "
        "compliances `--effects examples/thresholds.py`, "
        f"{len(d.ranking)} candidates): verdict *{d.verdict}*. The ranking is led by "
        f"{lead}{sig_txt}. The best effort by BIC is {be}, with parameters {be_vals}, "
        f"which predicts held-out sag to {be_cv:.2f} mm against {best['cv']:.2f} without it"
        + (f"; the rule: {refusal(acc)}" if acc is not None and not acc.improves else "")
        + ". `eodarm report --effects examples/thresholds.py` "
        + (
            "takes the same path (the bodies, then the mounts) and stops there: "
            if same
            else "ends at " + ", ".join(s.key for s in inv.final_model) + ": "
        )
        + f"{inv.stopped}.\n"
    )
    na_fit_und = list(best_na["undetermined"])
    na_bound = best_na.get("at_bound", [])
    w.append(
        "**Without the angle channels** (fitted to the sag and the motor sensors only, the "
        "same models; `python scripts/seed_investigation.py` prints the table): bodies + mounts "
        f"fit the sag in-sample to {best_na['rms']:.2f} mm but hold out to "
        f"{best_na['cv']:.2f} mm, "
        + ("worse" if best_na["cv"] > best["cv"] else "better")
        + f" than with the angles ({best['cv']:.2f}), and no added "
        "effect brings it below "
        f"{min(r['cv'] for r in noang[1:] if r['n'] > 0):.2f} mm. The measured angles are "
        "what keeps the physics from overfitting the 15 sags"
        + (
            ": without them the fit flags " + ", ".join(na_fit_und) + " as not determined"
            if na_fit_und
            else ""
        )
        + (" and " + ", ".join(na_bound) + " runs to its bound" if na_bound else "")
        + ".\n"
    )
    top_added = list(top["added"]) if top is not best else []
    loose_top = [a for a in top_added if a["at_bound"] or a["undetermined"]]
    top_note = (
        ", whose added parameters are all at their bound or not determined by the data: "
        "it is §4's best in effect"
        if top_added and len(loose_top) == len(top_added)
        else ""
    )
    verdict_line = (
        "Some models beat the line: " + ", ".join(beats_line)
        if beats_line
        else f"**Nothing beats the line through zero** ({line['cv']:.2f} mm): the best physics "
        f"model held out is {top['label']} at {top['cv']:.2f} mm{top_note}"
    )
    w.append(
        f"**Conclusion.** {verdict_line}; "
        + ("nothing reaches 1.0 mm. " if not below_1 else f"below 1.0 mm: {', '.join(below_1)}. ")
        + f"The physics (bodies + mounts) predicts configurations {', '.join(better_line)} better "
        f"than the line and {', '.join(worse_line)} worse; the line's advantage is "
        "configuration 5, the extreme pose, which the physics predicts from the four others "
        f"with {best['per_config']['c5']:.2f} mm against the line's "
        f"{line['per_config']['c5']:.2f} mm. The "
        "threshold the sag intercepts point at is not found by any mechanism written here: "
        "either it acts through something that also moves the angles in a way these models do "
        "not describe, or it lies in the measurements themselves (NOTES.md: the measured angles "
        "and the measured sag of configurations 4 and 5 disagree under rigid kinematics); 15 "
        "states cannot say which.\n"
    )
    confused = "; ".join(
        f"`{x}` and `{y}` cannot be told apart on the measured channels (the diagnosis: a "
        f"{a['channel']['channel']} channel would separate them"
        + (f", or {a['memory']}" if a.get("memory") else "")
        + ")"
        for a in d.advice
        for x, y in [a["pair"]]
    )
    w.append(
        "**Where the data cannot tell.** 5 configurations × 3 payloads is 15 states, and "
        "`eodarm fit` flags as not determined (relative standard error above 100 % or "
        "correlation beyond 0.95) in at least one of these models: "
        + ", ".join(f"`{u}`" for u in undetermined)
        + ". The stiffnesses of "
        + ", ".join(f"`{u.split(' (')[0]}`" for u in best["undetermined"])
        + " are only bounded from below (the motor "
        f"sensors read micrometres); each preload relief is within {max_z:.1f} standard errors "
        "of zero; "
        + (confused + "; " if confused else "")
        + "the threshold force F_T of examples/thresholds.py is not determined at all, because "
        "every force change of every state is far above it. The one-slope line has no such "
        "problem, which is part of why it predicts as well as it does: on 15 states, one "
        "parameter is hard to beat.\n"
    )
    return "\n".join(w)
