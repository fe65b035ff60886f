"""Regenerate docs/seed-reproduction.md and its figures from the bundled seed2022 data set.

Usage: python scripts/seed_reproduction.py [--out docs]

Everything in the document is computed here, from the published tables (NOTES.md) and the
project's own models; nothing is typed in by hand.
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path
from typing import Any

import numpy as np

import eodarm
from eodarm.analysis import calibrate
from eodarm.analysis.crossval import cross_validate
from eodarm.analysis.fit import FitWarning, compare, fit
from eodarm.data import datasets
from seed_verdicts import best_candidate, judged, refusal

BODIES = [f"actuator_compliance@M{i}" for i in (1, 2, 3)]
MOUNTS = [f"mount_compliance@M{i}" for i in (1, 2, 3)]


def rms(x: np.ndarray) -> float:
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x**2)))


def md_table(head: list[str], rows: list[list[Any]]) -> str:
    def cell(v: Any) -> str:
        if isinstance(v, float):
            return f"{v:.4g}" if abs(v) < 1e4 else f"{v:.4e}"
        return str(v)

    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(cell(v) for v in r) + " |" for r in rows]
    return "\n".join(out)


def report_paragraph(final: Any, meas: Any) -> str:
    """What `eodarm report` says of its final model, its undetermined parameters and the fitted
    file it hands over: computed with the tool's own functions (the report's interval, the
    hand-over's settling and [fit] table, `solve --uncertainty`)."""
    from eodarm.analysis.handover import fitted_arm, settle
    from eodarm.viz.format import bounded_interval, value

    flagged = final.undetermined()
    named = [
        f"{final.slots[i].key} ({why}; 95 % interval "
        + bounded_interval(*final.interval(i), final.slots[i].kind.unit, final.stderr(i))
        + ")"
        for i, why in flagged
    ]
    params = (
        "the fitted parameters, with " + " and ".join(named) + " flagged *not determined*, "
        "to be determined by more poses that load them differently"
        if named
        else "the fitted parameters, every one determined by the data"
    )
    text = (
        "`eodarm report` (no arguments) tells this story on one page: it opens with the final "
        "model, the verdict of the last round, the sag RMS from the baseline to the final "
        "model in-sample and held out against σ, the paper's two models beside it, what is "
        f"left, {params}, this budget, and the fitted arm file with the commands that use it."
    )
    fitted = fitted_arm(settle(final), data=str(meas.source))
    bounded = fitted.bounded()
    if bounded:
        text += " That file fixes what the data give only a bound for at its physical end: " + (
            "; ".join(
                f"{e.key} {'stiffer than' if m.bound == 'lower' else 'at most'} "
                f"{value(m.limit or 0.0, e.kind.unit, 3)}, treated as "
                f"{'rigid' if m.bound == 'lower' else 'absent'} and marked "
                f'`determined = {str(m.determined).lower()}`, `bound = "{m.bound}"`'
                for e, m in bounded
            )
            + " (docs/model.md, Undetermined parameters)."
        )
    rec = fitted.fit
    if rec is None or rec.explained is not False:
        return text + "\n"
    inad = dict(rec.sigma_model)
    j = meas.channels.index("dy_mm")
    sol = eodarm.solve(fitted, meas.alpha_deg, meas.mass_kg, uncertainty=True)
    sig, sig_p = sol["sigma_dy_mm"], sol["sigma_param_dy_mm"]
    miss = meas.values[:, j] - sol["dy_mm"]
    k = int(np.nanargmax(np.abs(miss)))
    text += (
        f" The file says the model does not explain its data (χ²/dof {rec.chi2_per_dof:.0f}): "
        f"its `[fit]` table carries the held-out inadequacy (dy {inad['dy_mm']:.2f} mm), so "
        "`eodarm solve --arm fitted.toml --uncertainty` gives σ(dy) of "
        f"{np.nanmin(sig):.2f}–{np.nanmax(sig):.2f} mm at the measured states, where the "
        f"parameters alone give {np.nanmin(sig_p):.2f}–{np.nanmax(sig_p):.2f} mm (docs/model.md, "
        f"Prediction errors). The measured sag farthest from the prediction, "
        f"{meas.config[k]} at {meas.mass_kg[k]:g} kg, {abs(miss[k]):.1f} mm off, is then "
        f"{abs(miss[k]) / sig[k]:.1f}σ away (σ {sig[k]:.2f} mm) rather than "
        f"{abs(miss[k]) / sig_p[k]:.1f}σ (the parameters' {sig_p[k]:.2f} mm)."
    )
    return text + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent.parent / "docs")
    args = ap.parse_args()
    figdir = args.out / "figures"
    figdir.mkdir(parents=True, exist_ok=True)
    warnings.simplefilter("ignore", FitWarning)

    ds = datasets.load("seed2022")
    tables = ds.tables
    meas = ds.measurements
    arm = ds.arm
    t3 = tables["table3"].sort_values(["config", "mass_kg"]).reset_index(drop=True)
    t5 = tables["table5"].sort_values(["config", "mass_kg"]).reset_index(drop=True)
    t8 = tables["table8"].sort_values(["config", "mass_kg"]).reset_index(drop=True)
    t9 = tables["table9"].sort_values(["config", "mass_kg"]).reset_index(drop=True)
    alpha = t3[[f"alpha{k}_unloaded_deg" for k in (1, 2, 3)]].to_numpy(float)
    mass = t3["mass_kg"].to_numpy(float)
    f_paper = t5[["F1_N", "F2_N", "F3_N"]].to_numpy(float)
    sag_meas = t9["measured_sag_mm"].to_numpy(float)
    labels = [f"{c}/{m:g}" for c, m in zip(t3["config"], t3["mass_kg"], strict=True)]

    doc: list[str] = []
    w = doc.append
    w("# The seed paper's data: reproduction and diagnosis\n")
    w(
        "Generated by `python scripts/seed_reproduction.py` from the bundled data set "
        "`seed2022` (Ștefan et al., *Electronics* 2022, 11, 2355; tables as published in "
        "`python/eodarm/data/seed2022/`, every interpretation in its `NOTES.md`). "
        "Do not edit by hand.\n"
    )

    # ---------------------------------------------------------------- 1. calibration
    cal_all = calibrate.seed2022_calibration(tables)
    cal = cal_all["calibration"]
    w("## 1. Does Table 1 reproduce Table 5? Calibrating the geometry\n")
    from eodarm.analysis.calibrate import GeomParam, calibrate_geometry

    printed = eodarm.Arm.from_dict(datasets.seed2022_published_dict())

    def pay(a: eodarm.Arm) -> np.ndarray:
        return np.column_stack([np.zeros_like(mass), -mass * a.g])

    only_b0 = calibrate_geometry(
        printed,
        alpha,
        None,
        f_paper,
        [GeomParam("base.B0.x", 1000.0, -550.0), GeomParam("base.B0.y", 1000.0, -60.0)],
        payload_fn=pay,
    )
    w(
        "Table 5 lists the actuator forces the paper computed for the 15 states, with the "
        "weights of arms and motors neglected. B0, the chassis pin of actuator 1, is printed "
        "nowhere. **With Table 1 exactly as printed (payload at O4 = 400 mm, g = 9.81) and B0 "
        f"fitted, Table 5 is not reproduced**: the best B0 runs off to "
        f"({only_b0.value[0]:.0f}, {only_b0.value[1]:.0f}) mm and the forces still miss by up "
        f"to {np.abs(only_b0.residual).max():.0f} N.\n"
    )
    pin_sigma = min(r["prior_sigma"] for r in cal.table())
    w(
        "So the calibration (`eodarm.analysis.calibrate.calibrate_geometry`, least squares "
        "through the "
        "compiled statics, each number pulled towards its printed value by a prior σ) also "
        "frees the doubtful numbers: the paper's g, the payload point on arm 3, the garbled "
        "cells A1 (`A180.9465`) and B2 (`B2−1280`), the clearly printed pins (σ = their "
        f"rounding, {pin_sigma:g} mm), and one lumped weight at O3: F1 and F2 carry constant "
        "offsets that "
        "no geometry gives with self-weight off (NOTES.md, Table 5), and a weight acting at "
        "joint O3 (link 3's mass at its own joint: no moment about O3, so F3 stays "
        "proportional to the payload, as printed) is the one load that produces exactly them. "
        f"Force σ = {cal.force_sigma:g} N (half the printed 0.1 N step).\n"
    )
    table = cal.table()
    post = {r["key"]: r["posterior_sigma"] for r in table}
    calv = {r["key"]: r["calibrated"] for r in table}
    printed_v = {r["key"]: r["printed"] for r in table}
    o3_load = calv["link[3].mass_kg"] * calv["g"]
    max_moved = max(abs(r["moved"]) for r in table if not r["identified"])
    rows = []
    for r in table:
        rows.append(
            [
                f"`{r['key']}`",
                r["printed"],
                r["calibrated"],
                r["moved"],
                r["prior_sigma"],
                r["posterior_sigma"],
                "yes" if r["identified"] else "no (stays printed)",
            ]
        )
    w(
        md_table(
            [
                "number",
                "printed",
                "calibrated",
                "moved",
                "prior σ",
                "posterior σ",
                "identified by Table 5",
            ],
            rows,
        )
    )
    w("")
    res = cal.residual
    w(
        f"The calibrated model reproduces all 45 forces of Table 5 to "
        f"{np.abs(res).max():.3f} N (RMS {rms(res):.3f} N), within the printed rounding.\n"
    )
    w(
        f"**What Table 5 identifies:** B0 (x to ±{post['base.B0.x']:.0f} mm, y to "
        f"±{post['base.B0.y']:.0f} mm: the actuator line is "
        "nearly horizontal, so its height is weakly constrained), the payload point on arm 3 "
        f"(x = {calv['link[3].next.x']:.0f} mm, i.e. the measurement point's abscissa, **not** "
        f"O4 at {printed_v['link[3].next.x']:.0f} mm), the "
        f"paper's g ({calv['g']:.1f} m/s², jointly with the lever: F3 fixes only g·x, F2 "
        "separates them through the "
        f"{printed_v['link[2].next.x']:.0f} mm of arm 2), and the {o3_load:.1f} N at O3. "
        "**What it cannot identify:** the "
        "garbled cells A1 and B2 and the other printed pins are *consistent* with Table 5 (they "
        f"moved by at most {max_moved:.2f} mm, within their rounding) but not pinned down "
        "beyond their "
        "prior; the centres of mass C1–C3, every mass, every stiffness and O1 do not enter "
        "Table 5 at all.\n"
    )
    w(
        "`arm.toml` of the data set keeps this geometry with the real g = 9.81 m/s² (the "
        "paper rounded to 10) and assumed masses (none is published), because it describes the "
        "measured arm. `arm_published.toml` is Table 1 as printed with the calibrated B0.\n"
    )

    # ---------------------------------------------------------------- 2. Table 5
    w("## 2. Table 5: actuator forces\n")
    exact = cal.force_model
    ours = eodarm.solve(arm, alpha, mass, self_weight=False)["force_n"]
    rows = []
    for i in range(len(labels)):
        rows.append([labels[i], *f_paper[i], *exact[i], *ours[i]])
    w(
        f"Paper vs the calibrated reconstruction (g = {calv['g']:.2f}, the {o3_load:.1f} N at "
        f"O3) and vs the data set's `arm.toml` with self-weight off (g = {arm.g:g}, so "
        f"{100 * (1 - arm.g / calv['g']):.1f} % lower, and no O3 load):\n"
    )
    w(
        md_table(
            [
                "config/kg",
                "F1 paper",
                "F2 paper",
                "F3 paper",
                "F1 calib.",
                "F2 calib.",
                "F3 calib.",
                "F1 arm.toml",
                "F2 arm.toml",
                "F3 arm.toml",
            ],
            rows,
        )
    )
    w(
        f"\nRMS difference from the paper: calibrated reconstruction {rms(exact - f_paper):.3f} "
        f"N; `arm.toml` without self-weight {rms(ours - f_paper):.1f} N (the O3 load and g).\n"
    )

    # ---------------------------------------------------------------- 3. Table 8
    w("## 3. Table 8: actuators as 500 N/mm springs\n")
    spring = eodarm.solve(arm, alpha, mass)
    sag_ours = -spring["dy_mm"]
    rows = [
        [labels[i], t8["analytic_500Nmm_sag_mm"][i], sag_ours[i], sag_meas[i]]
        for i in range(len(labels))
    ]
    w(
        "The same spring model in eodarm (every actuator a 500 N/mm spring, loaded by the "
        "payload, pose closed exactly) against the paper's analytic Table 8 and the measured "
        "sag at B3:\n"
    )
    w(md_table(["config/kg", "Table 8 (paper)", "eodarm 500 N/mm", "measured"], rows))
    w(
        f"\nOur spring model sags about {np.median(sag_ours / t8['analytic_500Nmm_sag_mm']):.1f}× "
        "more than the paper's Table 8 (median ratio). NOTES.md records that Table 8 could not "
        "be rebuilt from Table 5 with Δl = F/500 under any reading of the tables (≥ 1.9 mm "
        "RMS apart); §5 mentions unspecified joint imperfections in the paper's model. The "
        "difference is in the paper's calculation, which is not given, so Table 8 is kept as a "
        "published output.\n"
    )

    # ---------------------------------------------------------------- 4. errors
    w("## 4. The measured sag against the paper's models and ours\n")
    base = compare(arm, meas, [])
    models: list[tuple[str, list[str]]] = [
        ("actuator bodies fitted (dl channels)", BODIES),
        ("bodies + mounts (compliance outside the actuators)", BODIES + MOUNTS),
    ]
    rows = [
        [
            "paper, analytic 500 N/mm (Table 8)",
            rms(t8["analytic_500Nmm_sag_mm"] - sag_meas),
            "—",
            "none fitted",
        ],
        ["paper, FEM (Table 9)", rms(t9["fem_sag_mm"] - sag_meas), "—", "none fitted"],
        [
            "eodarm, 500 N/mm springs (baseline)",
            base.rms()["dy_mm"],
            base.rms()["dy_mm"],
            "none fitted",
        ],
    ]
    ladder = []
    ladder.append(
        {
            "label": "500 N/mm springs",
            "rms": base.rms(),
            "cv_rms": base.rms(),
            "chi2_per_dof": base.chi2_per_dof,
        }
    )
    fits = {}
    for label, eff in models:
        r = fit(arm, meas, eff)
        cv = cross_validate(arm, meas, eff)
        fits[label] = (r, cv)
        rows.append(
            [f"eodarm, {label}", r.rms()["dy_mm"], cv["rms"]["dy_mm"], f"{len(eff)} parameters"]
        )
        ladder.append(
            {
                "label": label.split(" (")[0],
                "rms": r.rms(),
                "cv_rms": cv["rms"],
                "chi2_per_dof": r.chi2_per_dof,
            }
        )
    w(md_table(["model", "sag RMS (mm)", "held-out RMS (mm)", "fitted"], rows))
    best_r, best_cv = fits[models[-1][0]]
    w(
        "\n'Held-out' is leave-one-configuration-out cross-validation: the parameters are "
        "fitted on four configurations and the fifth is predicted. The paper's models are "
        "not fitted to the measurements, so their error is already out-of-sample.\n"
    )
    per = best_cv["per_config"]
    w(
        "Held-out sag RMS per configuration of the best model: "
        + ", ".join(f"{k} {v['dy_mm']:.2f} mm" for k, v in per.items())
        + ".\n"
    )
    # the two configurations held out worst, in their order
    worst = sorted(int(k.lstrip("c")) for k in sorted(per, key=lambda k: per[k]["dy_mm"])[-2:])
    t6 = tables["table6"].sort_values(["config", "mass_kg"]).reset_index(drop=True)
    t6_err = {
        c: rms((t6["model_sag_mm"] - t6["measured_sag_mm"])[t6["config"] == c]) for c in worst
    }
    from eodarm.analysis.diagnose import all_slots

    taken = set(BODIES + MOUNTS)
    extra_cv, extra_absent = {}, []
    for slot in all_slots(3):
        if slot.key in taken:
            continue
        r_x = fit(arm, meas, [*BODIES, *MOUNTS, slot.spec])
        cv_x = cross_validate(arm, meas, [*BODIES, *MOUNTS, slot.spec], start=r_x.theta)
        extra_cv[slot.spec] = cv_x["rms"]["dy_mm"]
        if r_x.at_bound[-1] and r_x.theta[-1] == 0:
            extra_absent.append(slot.spec)  # fitted to no effect: the model unchanged
    base_cv = best_cv["rms"]["dy_mm"]
    lower = {k: v for k, v in extra_cv.items() if v < base_cv - 5e-3}
    found = {k: v for k, v in extra_cv.items() if k not in extra_absent}
    best_found = min(found, key=lambda k: found[k]) if found else None
    if lower:
        extra_txt = (
            "Adding one further effect of the catalogue lowers the held-out sag error for "
            + ", ".join(f"{k} ({v:.2f} mm)" for k, v in sorted(lower.items(), key=lambda x: x[1]))
            + f"; every one of the {len(extra_cv)} was tried."
        )
    else:
        extra_txt = (
            f"Adding any one further effect of the catalogue (every one of the {len(extra_cv)} "
            f"was tried) leaves the held-out sag error at {min(extra_cv.values()):.2f} mm or "
            f"more: {len(extra_absent)} of them fit to no effect on all the data"
            + (
                f", and the best of the others, {best_found}, holds out to "
                f"{found[best_found]:.2f} mm."
                if best_found
                else "."
            )
        )
    w(
        f"**Result.** The best model predicts held-out configurations to "
        f"{best_cv['rms']['dy_mm']:.2f} mm RMS, against the paper's "
        f"{rms(t8['analytic_500Nmm_sag_mm'] - sag_meas):.2f} mm (analytic) and "
        f"{rms(t9['fem_sag_mm'] - sag_meas):.2f} mm (FEM). **It does not reach the 1.0 mm "
        f"goal.** The held-out error sits in configurations {worst[0]} and {worst[1]}, and "
        "the data say why: "
        "the measured angles and the measured sag of those configurations disagree with each "
        "other under any rigid-link kinematics (the paper's own Table 6, which turns the "
        f"measured angles into sag, misses the measured sag by {t6_err[worst[1]]:.1f} mm RMS "
        f"in configuration {worst[1]} and {t6_err[worst[0]]:.1f} mm in {worst[0]}), "
        "configuration 5's motor-1 readings "
        "are ten times smaller than in the other configurations at larger forces, and "
        "configuration 5 is the extreme pose, so leaving it out turns its prediction into an "
        "extrapolation. " + extra_txt + "\n"
    )

    # ---------------------------------------------------------------- 5. the workflow
    w("## 5. The workflow on the real data\n")
    from eodarm.analysis.workflow import investigate

    inv = investigate(arm, meas)  # what `eodarm report` runs: diagnose, add, diagnose again
    d1 = inv.rounds[0]
    d2 = eodarm.diagnose(arm, meas, model=BODIES)
    d3 = eodarm.diagnose(arm, meas, model=BODIES + MOUNTS)
    b = base.rms()
    w(
        "1. **Compare** the spring model (`eodarm compare measurements.csv --arm arm.toml`): "
        f"χ²/dof = {base.chi2_per_dof:.0f}. It predicts actuator elongations of "
        f"{rms(spring['dl_mm']):.2f} mm RMS where the motor sensors read "
        f"{rms(meas.values[:, [meas.channels.index(f'dl{k}_mm') for k in (1, 2, 3)]]):.3f} mm "
        f"(RMS error {b['dl1_mm']:.2f} / {b['dl2_mm']:.2f} / {b['dl3_mm']:.2f} mm on the three "
        "motors): the measured elongations are tens of times too small for 500 N/mm bodies to "
        "turn the arm as much as it turns.\n"
    )

    def rule_says(d: Any) -> str:
        acc = d.acceptance
        if acc is None:
            return "the acceptance rule did not judge it"
        if not acc.improves:
            return f"the acceptance rule finds that it does not improve the model: {refusal(acc)}"
        return (
            "the acceptance rule finds that it improves the model, though it does not explain "
            "the data (" + "; ".join(acc.reasons()) + ")"
        )

    f1 = d1.best_effort_fit if d1.best_effort else d1.suggested_fit
    if f1 is not None:
        k0 = [a.stiffness_n_per_mm for a in arm.actuators]
        ratio = [f1.estimate(i) / k0[int(s.at[1:]) - 1] for i, s in enumerate(f1.slots)]
        w(
            "2. **Diagnose** (`eodarm diagnose ...`): verdict "
            f"*{d1.verdict}*: no set of up to three effects explains these data within their "
            f"stated σ (the best leaves χ²/dof = {f1.chi2_per_dof:.0f}), so nothing is "
            "*suggested*. The best effort, the set the information criterion prefers, is "
            f"{', '.join(s.key for s in d1.best_effort)}, and {rule_says(d1)}: the bodies are "
            + ", ".join(f"{f1.estimate(i):.3g}" for i in range(len(f1.slots)))
            + f" N/mm, {min(ratio):.0f} to {max(ratio):.0f} times stiffer than the arm file's "
            f"{min(k0):g} N/mm. With only the bodies changed, the arm is now far too stiff (sag "
            f"RMS {f1.rms()['dy_mm']:.1f} mm).\n"
        )
    else:
        w("2. **Diagnose**: no set suggested.\n")
    top = [c.slot.key for c in d2.ranking[:3]]
    f2 = d2.best_effort_fit if d2.best_effort else d2.suggested_fit
    w(
        "3. **Add the bodies and diagnose again** (`--add actuator_compliance@M1 ... @M3`): "
        f"verdict *{d2.verdict}*, ranking led by {', '.join(top)}; best effort "
        f"{', '.join(s.key for s in d2.best_effort or d2.suggested)}, and {rule_says(d2)}. "
        "**The compliance sits outside the "
        "actuator bodies, in series with them**: mounts and pins, as the authors concluded "
        "only after opening the joints (§7: elasticity 'in the articulation area between the "
        "motor and the robotic arm'). The motor sensors are what decide it: without the "
        "`dlK_mm` channels a soft body and a soft mount are indistinguishable, and the tool "
        "says so (`confused_with`).\n"
    )
    if f2 is not None:
        w(
            md_table(
                ["effect", "estimate", "± stderr"],
                [
                    [s.key, f"{f2.estimate(i):.4g} {s.kind.unit}", f"{f2.stderr(i):.3g}"]
                    for i, s in enumerate(f2.slots)
                ],
            )
        )
        w("")
    gaps = [c for c in d3.ranking if c.slot.name in ("joint_clearance", "actuator_play")]
    gap_est = [c.fit.estimate(c.fit.slots.index(c.slot)) for c in gaps]
    gap_txt = ", ".join(
        f"{c.slot.spec} {v:.2g} mm (Δχ² {max(c.delta_chi2, 0.0):.1f})"
        for c, v in zip(gaps[:3], gap_est[:3], strict=True)
    )
    gap_head = (
        f"All {len(gaps)} gap candidates, each added alone, fit to zero, e.g. "
        if all(v == 0 for v in gap_est)
        else "The gap candidates fit: "
    )
    intercepts = {}
    for c in sorted(set(t9["config"])):
        sel = t9["config"] == c
        _slope, icpt = np.polyfit(t9["mass_kg"][sel], t9["measured_sag_mm"][sel], 1)
        intercepts[c] = icpt
    negative = sum(v < 0 for v in intercepts.values())
    top3 = d3.ranking[0]
    be3 = d3.acceptance
    be3_txt = ""
    if d3.best_effort and be3 is not None and be3.cv is not None and be3.baseline_cv is not None:
        be3_txt = (
            f" (its held-out sag RMS: {be3.cv['rms']['dy_mm']:.2f} mm against "
            f"{be3.baseline_cv['rms']['dy_mm']:.2f} mm without it)"
        )
    stop_at = ", ".join(inv.steps[-1]["effects"]) if inv.steps else "the baseline"
    same_path = [s.key for s in inv.final_model] == BODIES + MOUNTS and len(inv.rounds) == 3
    w(
        "4. **The error falls**, in-sample and held out (the ladder of §4 and the figure "
        "below). A third diagnosis with the mounts in the model still says "
        f"*{d3.verdict}*, because the best model's χ²/dof is {d3.baseline.chi2_per_dof:.0f}: "
        f"the residuals are about {np.sqrt(d3.baseline.chi2_per_dof):.0f}× the stated σ, and "
        "no single effect of the catalogue removes that: "
        + best_candidate(
            top3.slot.key,
            top3.delta_chi2,
            d3.significance,
            len(d3.ranking),
            judged(d3, [top3.slot.key]),
        )
        + ". "
        + (
            "The investigation (`eodarm report`) takes the same three rounds and stops "
            f"there, at {stop_at}: {inv.stopped}{be3_txt}. "
            if same_path
            else f"The investigation (`eodarm report`) ends at {stop_at}: {inv.stopped}. "
        )
        + gap_head
        + f"{gap_txt}. The data "
        "contain no sign of a gap as docs/model.md §4 models it (centred unloaded, closed "
        "under any load, so it adds sag already at the lightest payload): a straight line "
        "through each configuration's three sags meets zero payload at "
        + ", ".join(f"{v:+.1f}" for v in intercepts.values())
        + f" mm, negative in {negative} of {len(intercepts)} configurations, where a gap "
        "would make it positive. The 0.1–0.3 mm of wear play the authors found when they "
        "opened the joints is therefore not visible in these measurements; the compliance in "
        "series with the actuators is.\n"
    )

    from eodarm.viz import plots

    plots.ladder(ladder, channel="dy_mm", path=figdir / "seed-ladder.png")
    plots.measured_vs_model(
        meas,
        {"500 N/mm springs": base, "bodies + mounts": best_r},
        path=figdir / "seed-measured-vs-model.png",
    )
    plots.residual_vs_payload(
        meas, base, best_r, channel="dy_mm", path=figdir / "seed-residual-vs-payload.png"
    )
    plots.deflection_share(arm, meas, best_r.effects, path=figdir / "seed-deflection-share.png")
    w("![ladder](figures/seed-ladder.png)\n")
    w("![measured vs model](figures/seed-measured-vs-model.png)\n")
    w("![residual vs payload](figures/seed-residual-vs-payload.png)\n")
    w("![sag budget](figures/seed-deflection-share.png)\n")
    from eodarm.viz.budget_plot import budget_at

    bud, bmass, _bmeas, _ = budget_at(arm, meas, best_r.effects)
    bodies = sum(bud.shares[i] for i, lb in enumerate(bud.labels) if lb.endswith("body"))
    mounts = sum(bud.shares[i] for i, k in enumerate(bud.keys) if k[0].startswith("mount"))
    w(
        f"**Who makes the sag** (the sag budget above, docs/diagnosis.md): at {bmass:g} kg the "
        f"best model sags {-bud.total.max():.1f} to {-bud.total.min():.1f} mm; the three mounts "
        f"make {-mounts.max():.1f} to {-mounts.min():.1f} mm of it and the three actuator "
        f"bodies {-bodies.max():.2f} to {-bodies.min():.2f} mm (each part's Shapley share, "
        "with all the others present, from the rigid arm; the shares add up to the model's "
        "sag). The stiff fitted bodies barely stretch: the compliance is in the mounts.\n"
    )
    w(report_paragraph(inv.final_fit, meas))
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import seed_investigation  # registers the user effects of examples/: run it last

    w(seed_investigation.section(arm, meas))
    (args.out / "seed-reproduction.md").write_text("\n".join(doc) + "\n", encoding="utf-8")
    print(f"wrote {args.out / 'seed-reproduction.md'} and 4 figures in {figdir}")


if __name__ == "__main__":
    main()
