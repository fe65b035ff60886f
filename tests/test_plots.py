"""Figures (eodarm.viz.plots) and the HTML report (eodarm.viz.report).

Promises tested here: every figure shows what it says (one panel per measured channel or per
configuration, one series per model, units on the axes, the plotted numbers are the fitted
ones, the bars of the sag add up to what the solver says); nothing is written unless a path is
given, and then a PNG at 120 dpi; no global matplotlib state is touched; the report is one
self-contained HTML file that names the verdict and every ranked candidate.
"""

from __future__ import annotations

import base64
import re
import subprocess
import sys
from pathlib import Path

import matplotlib
import numpy as np
import pytest
from matplotlib.figure import Figure

import eodarm
from eodarm.analysis.diagnose import Diagnosis, diagnose
from eodarm.analysis.fit import compare
from eodarm.analysis.ladder import build_ladder
from eodarm.analysis.residuals import residual_pattern
from eodarm.analysis.synth import random_configs, synth
from eodarm.data.datasets import example_arm
from eodarm.data.measurements import Measurements
from eodarm.errors import EodarmError
from eodarm.viz import plots, style
from eodarm.viz.report import write_report
from eodarm.viz.residual_map import residual_map
from outside import with_softening

HIDDEN = eodarm.Effect("joint_clearance", "O2", clearance_mm=0.12)
MASSES = (1.5, 5.0, 6.5)
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def arm() -> eodarm.Arm:
    return example_arm()


@pytest.fixture(scope="module")
def meas(arm: eodarm.Arm) -> Measurements:
    poses = random_configs(arm, 5, np.random.default_rng(3))
    return synth(arm, poses, MASSES, hidden=[HIDDEN], channels="dx_mm,dy_mm,dalpha", seed=4)


@pytest.fixture(scope="module")
def diag(arm: eodarm.Arm, meas: Measurements) -> Diagnosis:
    return diagnose(arm, meas)


@pytest.fixture(scope="module")
def steps(arm: eodarm.Arm, meas: Measurements, diag: Diagnosis) -> list[dict]:
    return build_ladder(arm, meas, diag)


def by_gid(ax: matplotlib.axes.Axes, gid: str) -> matplotlib.lines.Line2D:
    found = [ln for ln in ax.get_lines() if ln.get_gid() == gid]
    assert len(found) == 1, f"expected one line '{gid}', found {len(found)}"
    return found[0]


def unit_of(channel: str) -> str:
    return "[deg]" if channel.endswith("_deg") else "[mm]"


# ---------------------------------------------------------------------------- the data used
def test_the_diagnosis_finds_the_hidden_effect(diag: Diagnosis) -> None:
    # the figures below tell this story; it must be the true one
    assert diag.verdict == "missing"
    assert [s.key for s in diag.suggested] == [HIDDEN.key]


# ---------------------------------------------------------------------------- measured vs model
def test_measured_vs_model_has_one_panel_per_channel_and_one_series_per_model(
    meas: Measurements, diag: Diagnosis
) -> None:
    fits = {"baseline": diag.baseline, "fitted": diag.suggested_fit}
    fig = plots.measured_vs_model(meas, fits)
    assert isinstance(fig, Figure)
    assert len(fig.axes) == len(meas.measured_channels) == 5
    for ax, ch in zip(fig.axes, meas.measured_channels, strict=True):
        assert unit_of(ch) in ax.get_xlabel() and unit_of(ch) in ax.get_ylabel()
        assert ax.get_xlabel().startswith("measured") and ax.get_ylabel().startswith("model")
        c = meas.index(ch)
        rows = meas.measured[:, c]
        title = ax.get_title().replace("\n", " ")
        for label, f in fits.items():
            line = by_gid(ax, f"model:{label}")
            # x = measured, y = this model's value, in the measurement's row order
            np.testing.assert_allclose(line.get_xdata(), meas.values[rows, c])
            np.testing.assert_allclose(line.get_ydata(), f.prediction[rows, c])
            rms = f.rms()[ch]
            assert f"{label} {style.num(rms)}" in title
    # one legend, below the panels (not over the data): the models, the configurations, y = x
    (legend,) = fig.legends
    names = [t.get_text() for t in legend.get_texts()]
    assert "model: baseline" in names and "model: fitted" in names
    assert all(f"configuration {c}" in names for c in meas.configs)
    assert any(n.startswith("y = x") for n in names)
    assert all(ax.get_legend() is None for ax in fig.axes)
    # the fitted model is within noise, the baseline is not
    assert diag.suggested_fit.rms()["dy_mm"] < 0.1 * diag.baseline.rms()["dy_mm"]


def test_measured_vs_model_refuses_a_fit_of_other_data(
    arm: eodarm.Arm, meas: Measurements, diag: Diagnosis
) -> None:
    other = synth(arm, meas.alpha_deg[:3], [2.0], hidden=[HIDDEN])
    with pytest.raises(EodarmError, match="other data"):
        plots.measured_vs_model(meas, {"a": diag.baseline, "b": compare(arm, other)})


# ---------------------------------------------------------------------------- residuals
def test_residual_vs_payload_has_one_panel_per_configuration(
    meas: Measurements, diag: Diagnosis
) -> None:
    before, after = diag.baseline, diag.suggested_fit
    fig = plots.residual_vs_payload(meas, before, after)
    assert len(fig.axes) == len(meas.configs) == 5
    c = meas.index("dy_mm")  # the default channel when dy is measured
    assert "dy" in fig.get_suptitle()
    first = fig.axes[0]
    for ax, label in zip(fig.axes, meas.configs, strict=True):
        assert first.get_shared_y_axes().joined(first, ax)
        assert ax.get_title().startswith(label)
        rows = np.flatnonzero(meas.config == label)
        rows = rows[np.argsort(meas.mass_kg[rows])]
        b, a = by_gid(ax, "before"), by_gid(ax, "after")
        np.testing.assert_allclose(b.get_xdata(), meas.mass_kg[rows])
        np.testing.assert_allclose(b.get_ydata(), before.residual[rows, c])
        np.testing.assert_allclose(a.get_ydata(), after.residual[rows, c])
        assert b.get_linestyle() == "--" and a.get_linestyle() == "-"
        assert b.get_markerfacecolor() == "none"
    assert "[mm]" in fig.axes[0].get_ylabel()
    assert "[kg]" in fig.axes[-1].get_xlabel()


def test_residual_vs_payload_defaults_to_the_worst_channel_without_dy(arm: eodarm.Arm) -> None:
    poses = random_configs(arm, 2, np.random.default_rng(8))
    hidden = eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=1500.0)
    m = synth(arm, poses, MASSES, hidden=[hidden], channels="dalpha")
    base = compare(arm, m)
    worst = max(
        m.measured_channels,
        key=lambda ch: np.sqrt(np.nanmean(base.z[:, m.index(ch)] ** 2)),
    )
    assert plots.main_channel(m, base) == worst
    fig = plots.residual_vs_payload(m, base, base)
    assert len(fig.axes) == 2
    assert "[deg]" in fig.axes[0].get_ylabel()
    c = m.index(worst)
    rows = np.flatnonzero(m.config == m.configs[0])
    np.testing.assert_allclose(by_gid(fig.axes[0], "after").get_ydata(), base.residual[rows, c])
    # one model given twice is drawn once
    assert not any(ln.get_gid() == "before" for ln in fig.axes[0].get_lines())
    with pytest.raises(EodarmError, match="not measured"):
        plots.residual_vs_payload(m, base, base, channel="dy_mm")


# ---------------------------------------------------------------------------- ladder
def test_ladder_follows_the_diagnosis(diag: Diagnosis, steps: list[dict]) -> None:
    assert steps[0]["label"] == "baseline"
    assert steps[0]["rms"] == pytest.approx(diag.baseline.rms())
    assert [s["label"] for s in steps[1:]] == [f"+ {s.key}" for s in diag.suggested]
    assert steps[-1]["effects"] == [s.key for s in diag.suggested]
    assert steps[-1]["chi2_per_dof"] == pytest.approx(diag.suggested_fit.chi2_per_dof, rel=1e-3)
    chi = [s["chi2_per_dof"] for s in steps]
    assert chi == sorted(chi, reverse=True)
    # predicting a configuration it was not fitted on is no better than fitting it
    for s in steps:
        assert s["cv_rms"]["dy_mm"] >= s["rms"]["dy_mm"] * (1 - 1e-9)


def test_ladder_plots_the_steps_numbers(steps: list[dict]) -> None:
    fig = plots.ladder(steps, channel="dy_mm")
    ax = next(a for a in fig.axes if any(ln.get_gid() == "rms" for ln in a.get_lines()))
    np.testing.assert_allclose(by_gid(ax, "rms").get_ydata(), [s["rms"]["dy_mm"] for s in steps])
    np.testing.assert_allclose(
        by_gid(ax, "cv_rms").get_ydata(), [s["cv_rms"]["dy_mm"] for s in steps]
    )
    ax2 = next(a for a in fig.axes if a is not ax)
    assert ax2.get_yscale() == "log"
    np.testing.assert_allclose(by_gid(ax2, "chi2").get_ydata(), [s["chi2_per_dof"] for s in steps])
    assert "[mm]" in ax.get_ylabel()
    ticks = [t.get_text() for t in ax.get_xticklabels()]
    assert [t.split("\n")[0] for t in ticks] == [s["label"] for s in steps]


def test_ladder_without_cross_validation_draws_no_cv_line() -> None:
    steps = [
        {"label": "baseline", "rms": {"dx_mm": 0.5}, "cv_rms": None, "chi2_per_dof": 300.0},
        {"label": "+ x@y", "rms": {"dx_mm": 0.02}, "cv_rms": None, "chi2_per_dof": 1.1},
    ]
    fig = plots.ladder(steps, channel="dx_mm")
    gids = {ln.get_gid() for a in fig.axes for ln in a.get_lines()}
    assert "rms" in gids and "cv_rms" not in gids
    with pytest.raises(EodarmError, match="dy_mm"):
        plots.ladder(steps, channel="dy_mm")


# ---------------------------------------------------------------------------- sag shares
def test_deflection_share_bars_add_up_to_the_solver(
    arm: eodarm.Arm, meas: Measurements, diag: Diagnosis
) -> None:
    extra = eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=5e7)
    effects = [*diag.suggested_fit.effects, extra]
    fig = plots.deflection_share(arm, meas, effects)
    (ax,) = fig.axes
    rows = [int(np.flatnonzero(meas.config == c)[0]) for c in meas.configs]
    alpha = meas.alpha_deg[rows]
    mass = float(np.max(meas.mass_kg))
    total = eodarm.solve(arm, alpha, mass, effects=effects)["dy_mm"]
    # one container per component (every actuator body, every effect), then the residual;
    # the components stack from the rigid arm's zero to the model's sag (Shapley shares)
    assert len(ax.containers) == arm.n + len(effects) + 1
    tops = sum(np.array([p.get_height() for p in cont]) for cont in ax.containers[:-1])
    np.testing.assert_allclose(tops, total, atol=1e-6)
    np.testing.assert_allclose(by_gid(ax, "total").get_ydata(), total)
    legend = " ".join(t.get_text() for t in fig.legends[0].get_texts())
    assert "actuator 1 body" in legend and "chassis tilt" in legend and "residual" in legend
    assert "[mm]" in ax.get_ylabel()
    assert [t.get_text() for t in ax.get_xticklabels()] == list(meas.configs)
    assert f"{mass:g} kg" in ax.get_title()


# ---------------------------------------------------------------------------- arm pose
def test_arm_pose_draws_the_joints_and_the_loaded_pose(arm: eodarm.Arm, meas: Measurements) -> None:
    alpha = meas.alpha_deg[0]
    geo = eodarm.forward(arm, alpha)
    plain = plots.arm_pose(arm, alpha)
    (ax,) = plain.axes
    joints = next(ln for ln in ax.get_lines() if ln.get_label() == "joints")
    np.testing.assert_allclose(np.c_[joints.get_xdata(), joints.get_ydata()], geo["O"][0, : arm.n])
    assert "[mm]" in ax.get_xlabel() and "[mm]" in ax.get_ylabel()
    assert not any("loaded" in str(ln.get_label()) for ln in ax.get_lines())

    out = eodarm.solve(arm, alpha[None, :], 6.5, effects=[HIDDEN])
    fig = plots.arm_pose(arm, alpha, out=out, scale=20.0)
    (ax,) = fig.axes
    assert "approximate" in fig.get_suptitle() and "×20" in fig.get_suptitle()
    loaded = [ln for ln in ax.get_lines() if str(ln.get_label()).startswith("loaded: links")]
    assert loaded and loaded[0].get_linestyle() == "--"
    moved = eodarm.forward(arm, alpha + 20.0 * out["dalpha_deg"][0])["O"][0]
    np.testing.assert_allclose(loaded[0].get_xydata(), moved[:2])
    with pytest.raises(EodarmError, match="one row"):
        plots.arm_pose(arm, alpha, out=eodarm.solve(arm, meas.alpha_deg[:2], 6.5))


# ---------------------------------------------------------------------------- files
def all_figures(
    arm: eodarm.Arm, meas: Measurements, diag: Diagnosis, steps: list[dict], tmp: Path | None
) -> dict[str, Figure]:
    def at(name: str) -> Path | None:
        return None if tmp is None else tmp / f"{name}.png"

    f0, f1 = diag.baseline, diag.suggested_fit
    out = eodarm.solve(arm, meas.alpha_deg[:1], 6.5, effects=f1.effects)
    return {
        "mvm": plots.measured_vs_model(meas, {"baseline": f0, "fitted": f1}, path=at("mvm")),
        "rvp": plots.residual_vs_payload(meas, f0, f1, path=at("rvp")),
        "ladder": plots.ladder(steps, path=at("ladder")),
        "share": plots.deflection_share(arm, meas, f1.effects, path=at("share")),
        "pose": plots.arm_pose(arm, meas.alpha_deg[0], out=out, path=at("pose")),
        "left": residual_map(f0, path=at("left")),
    }


def test_nothing_is_written_without_a_path(
    arm: eodarm.Arm,
    meas: Measurements,
    diag: Diagnosis,
    steps: list[dict],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.chdir(tmp_path)
    rc = matplotlib.rcParams.copy()
    figs = all_figures(arm, meas, diag, steps, None)
    assert all(isinstance(f, Figure) for f in figs.values())
    assert list(tmp_path.iterdir()) == []
    # compare the stored values: RcParams' own == would resolve the backend itself
    assert dict.__eq__(matplotlib.rcParams, rc)


def test_a_png_at_120_dpi_is_written_when_asked(
    arm: eodarm.Arm, meas: Measurements, diag: Diagnosis, steps: list[dict], tmp_path: Path
) -> None:
    figs = all_figures(arm, meas, diag, steps, tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(f"{k}.png" for k in figs)
    for name, fig in figs.items():
        data = (tmp_path / f"{name}.png").read_bytes()
        assert data.startswith(PNG_MAGIC)
        width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
        w_in, h_in = fig.get_size_inches()
        assert (width, height) == (round(w_in * 120), round(h_in * 120))


def test_importing_and_plotting_leaves_pyplot_alone() -> None:
    # pyplot is where global figure state and backend switching live; a library must not
    # pull it in (nor, through it, pick a GUI backend for the caller)
    code = (
        "import sys; import eodarm.viz.plots as p; import eodarm.viz.report; "
        "p.ladder([{'label': 'a', 'rms': {'dy_mm': 1.0}, 'cv_rms': None, 'chi2_per_dof': 2.0}])"
        ".savefig(__import__('io').BytesIO()); "
        "print('matplotlib.pyplot' in sys.modules)"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert res.stdout.split() == ["False"]


# ---------------------------------------------------------------------------- report
def test_the_report_is_one_self_contained_html_file(
    arm: eodarm.Arm, meas: Measurements, diag: Diagnosis, steps: list[dict], tmp_path: Path
) -> None:
    path = write_report(
        tmp_path / "report.html",
        arm,
        meas,
        diag,
        steps=steps,
        cv=True,
        extra_sections=[("Bench notes", "<p>laser re-zeroed</p>")],
    )
    assert path == tmp_path / "report.html"
    assert [p.name for p in tmp_path.iterdir()] == ["report.html"]
    text = path.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>")
    # every image is embedded; nothing is fetched, nothing runs
    srcs = re.findall(r'\bsrc="([^"]*)"', text)
    assert len(srcs) >= 5
    for src in srcs:
        assert src.startswith("data:image/png;base64,")
        assert base64.b64decode(src.split(",", 1)[1]).startswith(PNG_MAGIC)
    lowered = text.lower()
    for banned in ("<script", "<link", "http://", "https://", "url(", "@import"):
        assert banned not in lowered
    # the story: verdict, suggestion, every candidate, the estimate, the extra section
    assert f'class="verdict {diag.verdict}"' in text
    said = re.sub(r"<[^>]+>", "", text)
    for cand in diag.ranking:  # in the ranking table, or named among those that do not help
        assert cand.slot.label in said
    est = diag.suggested_fit.estimate(0)
    assert f"{est:.5g}" in text
    assert "Bench notes" in text and "<p>laser re-zeroed</p>" in text
    assert "RMS cross-validated" in text


def test_the_report_of_an_adequate_model_says_so(arm: eodarm.Arm, tmp_path: Path) -> None:
    poses = random_configs(arm, 3, np.random.default_rng(5))
    m = synth(arm, poses, MASSES, channels="dx_mm,dy_mm", seed=2)
    d = diagnose(arm, m)
    assert d.verdict == "adequate" and not d.suggested
    steps = build_ladder(arm, m, d, cv=False)
    assert len(steps) == 1 and steps[0]["cv_rms"] is None
    text = write_report(tmp_path / "r.html", arm, m, d, steps=steps).read_text(encoding="utf-8")
    assert 'class="verdict adequate"' in text
    assert "nothing is missing" in text
    said = re.sub(r"<[^>]+>", "", text)
    assert all(c.slot.label in said for c in d.ranking)


@pytest.fixture(scope="module")
def unexplained(arm: eodarm.Arm) -> tuple[Measurements, Diagnosis]:
    """A softening body in actuator 2: no effect of the catalogue explains it."""
    poses = random_configs(arm, 5, np.random.default_rng(3))
    m = with_softening(arm, synth(arm, poses, MASSES, seed=4), 1, 400.0)
    return m, diagnose(arm, m)


def test_the_report_of_unexplained_data_says_so_and_shows_what_is_left(
    arm: eodarm.Arm, unexplained: tuple[Measurements, Diagnosis], tmp_path: Path
) -> None:
    m, d = unexplained
    assert d.verdict == "unexplained" and not d.suggested and d.best_effort
    steps = build_ladder(arm, m, d, cv=False)
    text = write_report(tmp_path / "r.html", arm, m, d, steps=steps, cv=True).read_text(
        encoding="utf-8"
    )
    assert 'class="verdict unexplained"' in text
    said = re.sub(r"<[^>]+>", "", text)
    assert "No effect of the catalogue explains these data." in said
    assert (
        "no effect of the catalogue explains these data; the largest remaining residuals are"
        in (said.lower())
    )
    best = ", ".join(s.key for s in d.best_effort)
    assert f"prefers {best}" in said and "it does not explain the data" in said
    # the rule's judgement of every set it looked at, with the reasons
    assert "The sets judged, in search order" in said
    assert said.count("refused") + said.count("improves") >= len(d.examined)
    # what is left: a table per channel and the heat map, after the residuals section
    left = text.split("<h2>6b. What no effect of the catalogue explains</h2>", 1)[1]
    left = left.split("<h2>", 1)[0]
    assert left.count('src="data:image/png;base64,') == 1
    for ch in m.measured_channels:
        assert f"<td>{ch}</td>" in left
    # every ranked candidate is still there
    said = re.sub(r"<[^>]+>", "", text)
    assert all(c.slot.label in said for c in d.ranking)


def test_residual_map_shows_the_mean_residual_per_configuration_and_payload(
    arm: eodarm.Arm, unexplained: tuple[Measurements, Diagnosis]
) -> None:
    m, d = unexplained
    fit = d.best_fit
    pat = residual_pattern(fit)
    fig = residual_map(fit)
    images = [im for ax in fig.axes for im in ax.get_images()]
    # one heat map per measured channel, rows = configurations, columns = payloads
    assert [im.get_gid() for im in images] == list(m.measured_channels) == list(pat.channels)
    z = fit.z
    for j, im in enumerate(images):
        grid = np.ma.filled(im.get_array(), np.nan)
        assert grid.shape == (len(m.configs), len(MASSES))
        c = m.index(pat.channels[j])
        for i, label in enumerate(m.configs):
            for p, mass in enumerate(MASSES):
                rows = (m.config == label) & (m.mass_kg == mass) & fit.problem.use[:, c]
                assert grid[i, p] == pytest.approx(float(np.mean(z[rows, c])), rel=1e-12)
    first = images[0].axes
    assert [t.get_text() for t in first.get_yticklabels()] == list(m.configs)
    bottom = images[-1].axes
    assert [t.get_text() for t in bottom.get_xticklabels()] == [f"{x:g}" for x in MASSES]
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert "mean (measured − model)/σ" in labels  # the shared colour bar says what colour is
    # a cell nobody measured is left empty, not drawn as zero
    gone = m.subset(~((m.config == m.configs[0]) & (m.mass_kg == MASSES[0])))
    grid = residual_map(compare(arm, gone)).axes[0].get_images()[0].get_array()
    assert grid.mask[0, 0] and not grid.mask[1:, :].any()


# ---------------------------------------------------------------------------- report, FE model
def _sag_baseline(text: str) -> dict[str, str]:
    """The 'baseline' column (the last) of the report's sag budget table, per configuration."""
    table = text.split("<h2>Who makes the sag?</h2>", 1)[1].split("</table>", 1)[0]
    rows = re.findall(r"<tr><td>([^<]+)</td>(.*?)</tr>", table)
    cell = r'<td class="num">([^<]+)</td>'
    # numbers are written with the minus sign (−), as everywhere a person reads them
    return {c: re.findall(cell, cells)[-1].replace("−", "-") for c, cells in rows}


def _baseline_rms(text: str) -> dict[str, str]:
    """The 'RMS baseline' column of the report's section 2, per channel."""
    table = text.split("<h2>2. Baseline", 1)[1].split("</table>", 1)[0]
    cell = r'<td class="num">([^<]+)</td>'
    return {ch: rms for ch, _, rms in re.findall(rf"<tr><td>([^<]+)</td>{cell}{cell}", table)}


def test_the_fe_report_names_its_model_and_agrees_with_the_analytic_to_first_order(
    arm: eodarm.Arm, tmp_path: Path
) -> None:
    # The FE model is linear on the undeformed geometry, the analytic one closes the loaded
    # pose exactly: their displacements differ at second order in the load (~0.6 % of the
    # sag at 6.5 kg on this arm), their actuator forces not at all (both are the statics of
    # the undeformed geometry; the sensors' dl is force/stiffness).
    poses = random_configs(arm, 5, np.random.default_rng(3))
    text: dict[tuple[str, float], str] = {}
    for model, scale in (("analytic", 1.0), ("fem", 1.0), ("fem", 1e-3)):
        m = synth(
            arm,
            poses,
            [scale * x for x in MASSES],
            hidden=[HIDDEN],
            channels="dx_mm,dy_mm,dalpha,dl",
            seed=4,
        )
        d = diagnose(arm, m, solver_model=model)
        steps = build_ladder(arm, m, d, cv=False)  # the diagnosis's model by default
        assert {s["fit"].problem.model for s in steps} == {model}
        path = write_report(
            tmp_path / f"{model}-{scale:g}.html", arm, m, d, steps=steps, cv=True, model=model
        )
        text[model, scale] = path.read_text(encoding="utf-8")
    fe, an = text["fem", 1.0], text["analytic", 1.0]
    # the report says which model made its numbers
    assert "finite-element model with 8 elements per flexible link" in fe
    assert "finite-element" not in an and "analytic: closed forms" in an
    # the sag of the model alone at the full payload: close, and not the same numbers
    s_fe, s_an = _sag_baseline(fe), _sag_baseline(an)
    assert s_fe.keys() == s_an.keys() == set(m.configs)
    diff = max(abs(float(s_fe[c]) - float(s_an[c])) for c in s_an)
    assert 0 < diff < 0.02 * max(abs(float(v)) for v in s_an.values())
    # ... and at 1/1000 of the payload the difference is below the 3 digits shown
    small = eodarm.solve(arm, poses, MASSES[-1] * 1e-3)["dy_mm"]
    from eodarm.viz.format import value

    assert _sag_baseline(text["fem", 1e-3]) == {
        c: value(float(v), digits=3, zeros=True).replace("−", "-")
        for c, v in zip(m.configs, small, strict=True)
    }
    # the actuator sensors' channels agree exactly, the displacements do not
    r_fe, r_an = _baseline_rms(fe), _baseline_rms(an)
    assert [r_fe[f"dl{i}_mm"] for i in (1, 2, 3)] == [r_an[f"dl{i}_mm"] for i in (1, 2, 3)]
    assert r_fe["dx_mm"] != r_an["dx_mm"] and r_fe["dy_mm"] != r_an["dy_mm"]


def test_the_report_refuses_to_mix_models(
    arm: eodarm.Arm, meas: Measurements, diag: Diagnosis, tmp_path: Path
) -> None:
    with pytest.raises(EodarmError, match="made with the analytic model, not the finite-el"):
        write_report(tmp_path / "r.html", arm, meas, diag, model="fem")
    with pytest.raises(EodarmError, match="made with the analytic model"):
        build_ladder(arm, meas, diag, cv=False, model="fem")
    with pytest.raises(ValueError, match="fem_options is for model='fem'"):
        write_report(tmp_path / "r.html", arm, meas, diag, fem_options={"elements_per_link": 4})
    fe_fit = compare(arm, meas, model="fem")
    with pytest.raises(EodarmError, match="final_fit was fitted with the finite-element model"):
        write_report(tmp_path / "r.html", arm, meas, diag, final_fit=fe_fit)
    assert not (tmp_path / "r.html").exists()


def test_report_command_with_the_fe_model(
    meas: Measurements, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from eodarm.cli import main

    csv = tmp_path / "m.csv"
    meas.to_csv(csv)
    out = tmp_path / "r.html"
    arm_file = tmp_path / "arm.toml"
    arm_file.write_text(example_arm().to_toml(), encoding="utf-8")
    args = ["report", str(csv), "--arm", str(arm_file), "--model", "fem"]
    args += ["--elements-per-link", "4", "--rounds", "1"]
    assert main([*args, "-o", str(out)]) == 0
    assert capsys.readouterr().out.startswith("the ladder of models")
    text = out.read_text(encoding="utf-8")
    assert "finite-element model with 4 elements per flexible link" in text
    assert "analytic: closed forms" not in text


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (("--model", "fea"), "argument --model: invalid choice: 'fea'"),
        (("--elements-per-link", "4"), "--elements-per-link needs --model fem"),
    ],
)
def test_report_command_refuses_a_bad_model_in_one_line(
    args: tuple[str, ...], needle: str, tmp_path: Path
) -> None:
    res = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from eodarm.cli import main; sys.exit(main())",
            "report",
            *args,
            "-o",
            str(tmp_path / "r.html"),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert res.returncode == 2
    assert res.stdout == ""
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], res.stderr
    assert not (tmp_path / "r.html").exists()
