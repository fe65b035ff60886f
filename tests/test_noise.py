"""Noise from repeats (docs/formats.md §3): where a channel has no sigma, states measured more than
once give it the pooled standard deviation of their repeats.

Promises tested here: the estimator is the pooled variance; on campaign-like data (repeats, no
sigma columns, real noise 2.5× the defaults) it finds the real noise within its sampling error;
fewer than 5 degrees of freedom or identical repeats fall back to the defaults and say why;
a given sigma wins; a subset keeps the estimate of the whole file; files round-trip; the
command line says so in one line per kind and its JSON keeps the contract's keys;
``synth --repeats K`` writes every state K times.
"""

from __future__ import annotations

import io
import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings

import eodarm
from eodarm.analysis.synth import random_configs, synth
from eodarm.cli import main
from eodarm.data.channels import channel_names, default_sigma
from eodarm.data.datasets import example_arm
from eodarm.data.measurements import Measurements
from eodarm.data.noise import MIN_DOF, pooled_sigma, state_groups
from eodarm.data.reader import from_dataframe, read_measurements
from strategies import repeated_values

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"

HEAD = "config,alpha1_deg,alpha2_deg,alpha3_deg,mass_kg"


@pytest.fixture(scope="module")
def arm() -> eodarm.Arm:
    return example_arm()


def as_read(meas: Measurements) -> Measurements:
    """The measurements as a reader sees their file (without sigma columns if so made)."""
    buf = io.StringIO()
    meas.to_csv(buf)
    buf.seek(0)
    return read_measurements(buf, meas.n)


def campaign(
    arm: eodarm.Arm, configs: int, repeats: int, noise: float, seed: int = 0
) -> Measurements:
    """Pure noise (no hidden effect), each state measured ``repeats`` times, no sigma columns."""
    alpha = random_configs(arm, configs, np.random.default_rng([7, seed]))
    made = synth(
        arm, alpha, [1.5, 5.0, 6.5], noise=noise, seed=seed, repeats=repeats, sigma_columns=False
    )
    return as_read(made)


# ---------------------------------------------------------------------------- the estimator
@settings(max_examples=200, deadline=None)
@given(repeated_values())
def test_pooled_sigma_is_the_pooled_variance_of_the_repeats(
    data: tuple[np.ndarray, np.ndarray],
) -> None:
    values, state = data
    ss = 0.0
    dof = states = rows = 0
    for g in np.unique(state):
        x = values[(state == g) & ~np.isnan(values)]
        ss += float(np.sum((x - x.mean()) ** 2)) if x.size else 0.0
        dof += max(x.size - 1, 0)
        states += x.size >= 2
        rows += x.size if x.size >= 2 else 0
    got = pooled_sigma(values, state)
    assert (got.dof, got.states, got.rows) == (dof, states, rows)
    if dof == 0:
        assert math.isnan(got.sigma)
        return
    want = math.sqrt(ss / dof)
    # numpy's deviations from the mean of values up to 1000 carry ~1e-13 of rounding
    assert got.sigma == pytest.approx(want, rel=1e-9, abs=1e-10)
    # identical repeats are exactly 0, not a rounding residue
    groups = [values[(state == g) & ~np.isnan(values)] for g in np.unique(state)]
    assert (got.sigma == 0.0) == all(np.all(x == x[:1]) for x in groups)


def test_a_state_is_config_angles_and_mass_exactly() -> None:
    config = ["a", "a", "a", "b", "a", "a"]
    alpha = [[90, 10, 0], [90, 10, 0], [90, 10, 1e-9], [90, 10, 0], [90, 10, 0], [90, 10, -0.0]]
    mass = [5.0, 5.0, 5.0, 5.0, 6.5, 5.0]
    assert state_groups(config, alpha, mass).tolist() == [0, 0, 1, 2, 3, 0]


# ---------------------------------------------------------------------------- on campaigns
def test_repeats_find_a_noise_larger_than_the_defaults(arm: eodarm.Arm) -> None:
    """20 configurations × 3 payloads × 5 repeats: ν = 240, σ known to 1/√(2ν) ≈ 4.6 %."""
    meas = campaign(arm, configs=20, repeats=5, noise=2.5)
    nu = 60 * (5 - 1)
    assert meas.n_rows == 300  # nothing averaged or dropped: every repeat is an observation
    assert meas.defaulted == () and meas.pooled == tuple(channel_names(3))
    for ch in meas.channels:
        rec = meas.noise[ch]
        assert (rec.source, rec.states, rec.rows, rec.repeat_dof) == ("repeats", 60, 300, nu)
        assert meas.sigma_dof[ch] == nu
        truth = 2.5 * default_sigma(ch)
        assert abs(rec.sigma / truth - 1.0) < 4.0 / math.sqrt(2 * nu), ch
        np.testing.assert_array_equal(meas.sigma[:, meas.index(ch)], rec.sigma)
    # the whitened residuals are then of unit size: the model fits within the noise
    fitted = eodarm.fit(arm, meas, [])
    assert 0.85 < fitted.chi2_per_dof < 1.15


def test_too_few_repeats_fall_back_to_the_defaults_and_say_why(arm: eodarm.Arm) -> None:
    # 2 configurations × 1 payload × 3 repeats: ν = 4 < 5
    alpha = random_configs(arm, 2, np.random.default_rng(3))
    few = as_read(synth(arm, alpha, [5.0], noise=2.5, repeats=3, sigma_columns=False))
    assert few.pooled == () and few.defaulted == tuple(few.channels)
    rec = few.noise["dy_mm"]
    assert (rec.source, rec.sigma, rec.repeat_dof, rec.dof) == ("default", 0.02, 4, math.inf)
    assert "4 degrees of freedom" in rec.reason and str(MIN_DOF) in rec.reason
    assert few.sigma_dof["dy_mm"] == math.inf
    # one more state gives 6: pooled
    more = as_read(synth(arm, alpha, [5.0, 6.5], noise=2.5, repeats=3, sigma_columns=False))
    assert more.noise["dy_mm"].source == "repeats" and more.sigma_dof["dy_mm"] == 8
    # without repeats, the reason says so
    once = as_read(synth(arm, alpha, [5.0], sigma_columns=False))
    assert once.noise["dy_mm"].reason == "no state was measured more than once"


def test_identical_repeats_fall_back_to_the_defaults(tmp_path: Path) -> None:
    # dy_mm rounded to 0.1 mm: every repeat reads the same; dx_mm scatters
    rows = [
        f"c{k},{80 + k},10,0,5,{0.31 + 0.01 * (r % 2) + k},-1.5" for k in range(6) for r in (0, 1)
    ]
    path = tmp_path / "rounded.csv"
    path.write_text(f"{HEAD},dx_mm,dy_mm\n" + "\n".join(rows) + "\n", encoding="utf-8")
    meas = read_measurements(path, 3)
    assert meas.noise["dx_mm"].source == "repeats" and meas.noise["dx_mm"].repeat_dof == 6
    assert meas.noise["dx_mm"].sigma == pytest.approx(0.01 / math.sqrt(2))
    rec = meas.noise["dy_mm"]
    assert rec.source == "default" and "identical" in rec.reason and rec.repeat_dof == 6
    assert meas.defaulted == ("dy_mm",) and meas.pooled == ("dx_mm",)
    assert np.all(meas.sigma[:, 1] == default_sigma("dy_mm"))


def test_a_given_sigma_wins_over_the_repeats(arm: eodarm.Arm) -> None:
    alpha = random_configs(arm, 4, np.random.default_rng(5))
    made = synth(arm, alpha, [1.5, 6.5], noise=2.5, repeats=3, channels="dx_mm,dy_mm")
    df = made.to_dataframe().drop(columns=["sigma_dx_mm"])
    # dy_mm: sigma given for the first of each state's 3 repeats; the other 2 (16 values,
    # 8 dof) are pooled among themselves
    sig = df["sigma_dy_mm"].to_numpy().copy()
    blank = np.arange(len(sig)) % 3 != 0
    sig[blank] = np.nan
    df["sigma_dy_mm"] = sig
    meas = from_dataframe(df, 3)
    assert meas.noise["dx_mm"].source == "repeats"
    j = meas.index("dy_mm")
    np.testing.assert_array_equal(meas.sigma[~blank, j], made.sigma[~blank, j])  # given: kept
    np.testing.assert_array_equal(meas.sigma_pooled[:, j], blank)
    rec = meas.noise["dy_mm"]
    assert (rec.source, rec.rows, rec.repeat_dof) == ("repeats", 16, 8)
    want = pooled_sigma(
        np.where(np.isnan(sig), df["dy_mm"], np.nan),
        state_groups(meas.config, meas.alpha_deg, meas.mass_kg),
    )
    assert rec.sigma == want.sigma
    # a full sigma column: given, whatever the repeats say
    full = from_dataframe(made.to_dataframe(), 3)
    assert {r.source for r in full.noise.values()} == {"given"}
    assert full.pooled == () and full.defaulted == ()
    assert all(v == math.inf for v in full.sigma_dof.values())
    np.testing.assert_array_equal(full.sigma, made.sigma)


def test_a_subset_keeps_the_estimate_of_the_whole_file(arm: eodarm.Arm) -> None:
    meas = campaign(arm, configs=4, repeats=3, noise=2.5, seed=2)
    first = meas.subset(meas.config == "c1")  # 3 states × 3: alone it would have ν = 6
    assert first.n_rows == 9
    for ch in meas.channels:
        assert first.noise[ch] == meas.noise[ch]
        assert first.sigma_dof[ch] == meas.sigma_dof[ch] == 24
    np.testing.assert_array_equal(first.sigma, meas.sigma[meas.config == "c1"])
    # even a single row keeps it
    one = meas.subset([0])
    assert one.noise["dy_mm"].sigma == meas.noise["dy_mm"].sigma and one.pooled == meas.pooled


def test_files_with_repeats_read_back_exactly(arm: eodarm.Arm, tmp_path: Path) -> None:
    meas = campaign(arm, configs=3, repeats=3, noise=2.5, seed=4)
    meas.to_csv(tmp_path / "again.csv")
    header = (tmp_path / "again.csv").read_text(encoding="utf-8").splitlines()[0]
    assert "sigma_" not in header  # pooled sigmas are not written: they are derived again
    back = read_measurements(tmp_path / "again.csv", 3)
    np.testing.assert_array_equal(back.values, meas.values)
    np.testing.assert_array_equal(back.sigma, meas.sigma)
    assert dict(back.noise) == dict(meas.noise)


def test_sigma_dof_covers_every_channel(tmp_path: Path) -> None:
    text = f"{HEAD},dy_mm,dl1_mm,sigma_dl1_mm\n" + "".join(
        f"c{k},90,{k},0,5,-1.{r}{k},-0.01,0.001\n" for k in range(3) for r in range(3)
    )
    path = tmp_path / "m.csv"
    path.write_text(text, encoding="utf-8")
    meas = read_measurements(path, 3)
    assert meas.sigma_dof == {ch: (6.0 if ch == "dy_mm" else math.inf) for ch in channel_names(3)}
    assert set(meas.noise) == {"dy_mm", "dl1_mm"} and meas.noise["dl1_mm"].source == "given"


# ---------------------------------------------------------------------------- command line
@pytest.fixture(scope="module")
def mixed_csv(arm: eodarm.Arm, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Repeats, no sigma columns; dl1_mm measured once per state (defaulted), the rest pooled."""
    meas = campaign(arm, configs=5, repeats=3, noise=2.5, seed=6)
    df = meas.to_dataframe()
    df = df[[c for c in df.columns if not c.startswith("sigma_") and c != "line"]]
    first = ~df.duplicated(["config", "alpha1_deg", "alpha2_deg", "alpha3_deg", "mass_kg"])
    df.loc[~first, "dl1_mm"] = np.nan
    path = tmp_path_factory.mktemp("noise") / "mixed.csv"
    df.to_csv(path, index=False)
    return path


def _messages(err: str) -> list[str]:
    """stderr as messages: a message wrapped within 100 columns continues on indented lines."""
    out: list[str] = []
    for line in err.splitlines():
        if line.startswith("  ") and out:
            out[-1] += " " + line.strip()
        else:
            out.append(line)
    return out


@pytest.mark.parametrize("command", ["compare", "diagnose", "fit"])
def test_cli_says_where_sigma_came_from_in_one_line_per_kind(
    mixed_csv: Path, command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [command, str(mixed_csv), "--arm", str(EXAMPLE), "--json"]
    if command == "fit":
        argv += ["--add", "joint_clearance@O3"]
    assert main(argv) == 0
    cap = capsys.readouterr()
    notes = [m for m in _messages(cap.err) if ("sigma" in m or "noise" in m) and "next:" not in m]
    assert len(notes) == 2, cap.err
    pooled, dflt = notes
    meas = read_measurements(mixed_csv, 3)
    assert pooled.startswith("eodarm: noise of dx_mm ") and "pooled from the repeats" in pooled
    assert f"dy_mm {meas.noise['dy_mm'].sigma:.2g} mm" in pooled
    assert "(15 states, 45 rows, 30 dof; docs/diagnosis.md)" in pooled
    assert "dl1_mm" not in pooled
    assert dflt == (
        "eodarm: no sigma given for dl1_mm 0.002: using the default noise levels, "
        "as no state was measured more than once (docs/diagnosis.md)"
    )
    doc = json.loads(cap.out)
    contract = {
        "compare": {"model", "rms", "chi2_per_dof"},
        "diagnose": {"model", "baseline", "verdict", "suggested", "ranking"},
        "fit": {"effects", "before", "after", "parameters", "covariance", "correlation"}
        | {"undetermined", "data_checks"},
    }[command]
    assert contract <= set(doc)
    if command == "fit":
        assert set(doc) == contract  # the contract's keys, exactly
        return
    noise = doc["noise"]
    assert noise["dy_mm"] == {
        "sigma": meas.noise["dy_mm"].sigma,
        "source": "repeats",
        "dof": 30,
        "states": 15,
        "rows": 45,
    }
    assert noise["dl1_mm"]["source"] == "default" and noise["dl1_mm"]["dof"] is None


def test_cli_with_given_sigmas_says_nothing_about_noise(
    arm: eodarm.Arm, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    alpha = random_configs(arm, 3, np.random.default_rng(2))
    synth(arm, alpha, [5.0], repeats=3).to_csv(tmp_path / "given.csv")
    assert main(["compare", str(tmp_path / "given.csv"), "--arm", str(EXAMPLE)]) == 0
    err = capsys.readouterr().err.split("eodarm: next:")[0]  # the next: line names the file
    assert "sigma" not in err and "noise" not in err


def test_cli_synth_repeats_writes_every_state_k_times(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "rep.csv"
    argv = ["synth", "--arm", str(EXAMPLE), "--configs", "4", "--masses", "1.5,6.5"]
    argv += ["--repeats", "3"]
    assert main([*argv, "--noise", "2.5", "--no-sigma-columns", "-o", str(out)]) == 0
    assert "wrote 24 rows (4 configs × 2 payloads × 3 repeats" in capsys.readouterr().err
    meas = read_measurements(out, 3)
    state = state_groups(meas.config, meas.alpha_deg, meas.mass_kg)
    # the three repeats of a state follow each other, with independent noise
    assert state.tolist() == [s for s in range(8) for _ in range(3)]
    v = meas.values.reshape(8, 3, -1)
    assert np.all(v.std(axis=1) > 0)
    assert meas.pooled == tuple(channel_names(3))
    assert meas.noise["dy_mm"].repeat_dof == 16
    # the same as synth(..., repeats=3) makes (a configuration: 2 payloads × 3 repeats)
    want = synth(example_arm(), meas.alpha_deg[::6], [1.5, 6.5], noise=2.5, seed=0, repeats=3)
    np.testing.assert_array_equal(meas.values, want.values)
    assert main(["synth", "--alpha", "90,10,0", "--repeats", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--repeats" in err[0]


def test_synth_with_one_repeat_is_unchanged(arm: eodarm.Arm) -> None:
    alpha = random_configs(arm, 3, np.random.default_rng(9))
    a = synth(arm, alpha, [1.5, 5.0], seed=3)
    b = synth(arm, alpha, [1.5, 5.0], seed=3, repeats=1)
    np.testing.assert_array_equal(a.values, b.values)
    three = synth(arm, alpha, [1.5, 5.0], seed=3, repeats=3)
    assert three.n_rows == 18 and three.line.tolist() == list(range(2, 20))
    np.testing.assert_array_equal(three.alpha_deg, np.repeat(a.alpha_deg, 3, axis=0))
    with pytest.raises(eodarm.EodarmError, match="repeats"):
        synth(arm, alpha, [1.5], repeats=0)


def test_the_lack_of_fit_test_does_not_count_the_repeats_twice() -> None:
    """With σ pooled from the repeats in the fit, their whitened scatter about the state means
    is exactly ν (s was made from it); the verdict tests only the misfit of the means, so a
    misfit that F(dof, ν) on χ²/dof would overlook is seen."""
    from eodarm.analysis.consistency import chi2_p_value, effective_nu, fit_p_value, within_states
    from eodarm.analysis.fit import compare

    arm = example_arm()
    alpha = random_configs(arm, 8, np.random.default_rng(11))
    clear = eodarm.Effect("joint_clearance", "O3", clearance_mm=0.02)
    meas = synth(
        arm,
        alpha,
        [1.5, 5.0, 6.5],
        hidden=[clear],
        channels="dy_mm",
        noise=2.5,
        seed=11,
        repeats=4,
        sigma_columns=False,
    )
    text = io.StringIO()
    meas.to_csv(text)
    text.seek(0)
    meas = read_measurements(text, arm.n)
    assert meas.pooled == ("dy_mm",)
    base = compare(arm, meas)
    w, nu_w = within_states(base)
    assert nu_w == meas.sigma_dof["dy_mm"]
    assert w == pytest.approx(nu_w, rel=1e-9)
    nu = effective_nu(meas, base.problem.use)
    lack = fit_p_value(base)
    naive = chi2_p_value(base.chi2, base.dof, nu)
    assert lack < naive  # the means' misfit is diluted by ν_W repeats in the naive test
    assert fit_p_value(compare(arm, meas, [clear])) > 1e-3  # the right model passes
