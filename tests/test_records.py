"""Raw records (docs/records.md): the steady states of a logger's records become a measurement
file whose values are the model's within their stated errors, whose errors are honest, and on
which diagnose finds the hidden effect; malformed records and unmatched states are refused in
one line and nothing is written."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import lfilter

import eodarm
from arms import ARMS, four_link_arm
from eodarm.analysis.diagnose import diagnose
from eodarm.analysis.records import mean_standard_error, steady_states
from eodarm.analysis.synth import random_configs
from eodarm.analysis.synth_records import synth_records, write_synth_campaign
from eodarm.cli import main
from eodarm.data.channels import channel_values
from eodarm.data.reader import read_measurements

SEQUENCE = [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0]
EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "example_arm.toml"


def ar1(rng: np.random.Generator, n: int, phi: float, size: int = 1) -> np.ndarray:
    """``size`` stationary AR(1) series of ``n`` samples, unit variance, coefficient ``phi``."""
    e = rng.standard_normal((n, size)) * math.sqrt(1 - phi * phi)
    z0 = rng.standard_normal(size) * phi
    return lfilter([1.0], [1.0, -phi], e, axis=0, zi=z0[None, :])[0]


# ---------------------------------------------------------------------- honest errors
@pytest.mark.parametrize(("phi", "white"), [(0.9, 0.0), (0.97, 0.0), (0.9, 0.5)])
def test_stated_standard_error_matches_the_scatter_of_the_mean(phi: float, white: float) -> None:
    """On AR(1) noise (and AR(1) plus white noise) the stated standard error of a plateau's mean
    is the scatter of that mean over many draws, within 20 % (the sample standard deviation
    over √N would understate it √((1+φ)/(1−φ)) times: 4.4 at φ = 0.9)."""
    rng = np.random.default_rng(5)
    draws, n = 400, 3000
    x = ar1(rng, n, phi, draws) + white * rng.standard_normal((n, draws))
    means = x.mean(axis=0)
    stated = np.array([mean_standard_error(x[:, i])[0] for i in range(draws)])
    scatter = means.std(ddof=1)
    # the scatter of 400 means is itself known to ±3.5 % (1σ), hence 20 % is a real test
    assert np.sqrt(np.mean(stated**2)) == pytest.approx(scatter, rel=0.20)
    naive = x.std(axis=0, ddof=1).mean() / math.sqrt(n)
    assert naive < 0.5 * scatter  # what the brief warns of: the correlated noise matters


def test_a_steady_record_is_one_state_with_no_drift() -> None:
    """Noise alone, however correlated, is one steady state and no drift (no false alarm in
    50 records of 8 channels)."""
    rng = np.random.default_rng(9)
    alarms = 0
    for _ in range(50):
        t = np.arange(6000) / 300.0
        states, _ = steady_states(t, ar1(rng, t.size, 0.95, 8))
        assert len(states) == 1
        alarms += states[0].drift
    assert alarms <= 1  # the test's family-wise rate is 0.1 % per record


def test_a_logger_that_writes_few_decimals_is_read_without_understating_the_errors() -> None:
    """Readings rounded to 0.01 (5 times the actuator sensors' noise): a channel that mostly
    stands still and flickers by one quantum neither breaks a state nor drifts, and its
    error is at least the quantisation's (q/√12), so the values stay within it."""
    from eodarm.analysis.records import analyse_record
    from eodarm.data.records import Record, RecordSpec

    arm = ARMS["example"]()
    alpha = solvable_configs(arm, 3, [])
    z = []
    for r in synth_records(arm, alpha, SEQUENCE, seed=8):
        values = np.round(r.values, 2)
        spec = RecordSpec(Path(f"{r.config}.csv"), r.config, r.alpha_deg, r.masses_kg)
        res = analyse_record(Record(spec.file, r.time_s, r.channels, values), spec)
        assert res.refused is None, res.refused
        for row in res.rows:
            for j, c in enumerate(r.channels):
                assert row["sigma"][c] >= 0.01 / math.sqrt(12) * math.sqrt(2) * 0.999
                z.append((row["values"][c] - r.truth[row["step"], j]) / row["sigma"][c])
    assert np.max(np.abs(z)) < 4.0


# ---------------------------------------------------------------------- rehearsal campaigns
def solvable_configs(arm: eodarm.Arm, k: int, hidden: list[eodarm.Effect]) -> np.ndarray:
    rng = np.random.default_rng(3)
    keep: list[np.ndarray] = []
    while len(keep) < k:
        for a in random_configs(arm, k, rng):
            try:
                eodarm.solve(arm, np.repeat(a[None], 2, axis=0), [0.0, 9.5], effects=hidden)
            except ValueError:
                continue
            keep.append(a)
    return np.array(keep[:k])


ARM_CASES = [
    ("two-link", ARMS["two-link"]),
    ("seed-like", ARMS["seed-like"]),
    ("four-link", four_link_arm),
]


@pytest.mark.parametrize(("name", "make"), ARM_CASES, ids=[c[0] for c in ARM_CASES])
def test_records_recover_the_values_and_diagnose_finds_the_hidden_effect(
    name: str, make: object, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A hidden mount compliance (no memory: one load from the reference is the same physics as
    a sequence) on 2-, 3- and 4-link arms: every written value is eodarm.solve's within its
    stated error's usual scatter, and diagnose on the written file names the effect."""
    arm = make()  # type: ignore[operator]
    k = arm.actuators[1].stiffness_n_per_mm * 0.8
    hidden = [eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=k)]
    alpha = solvable_configs(arm, 4, hidden)
    recs = synth_records(arm, alpha, SEQUENCE, hidden=hidden, seed=21)
    camp = write_synth_campaign(tmp_path / "rehearsal", recs)
    out = tmp_path / "meas.csv"
    assert main(["records", str(camp), "-o", str(out)]) == 0
    meas = read_measurements(out, arm.n)  # each record's rows one load sequence
    assert meas.has_sequences
    assert meas.n_rows == 4 * (len(SEQUENCE) - 1)
    truth = channel_values(
        eodarm.solve(arm, meas.alpha_deg, meas.mass_kg, effects=hidden), meas.channels
    )
    z = (meas.values - truth) / meas.sigma
    # honest errors: the RMS of ~200 z-scores is 1 within ±0.25; none beyond 5
    assert 0.75 < math.sqrt(np.nanmean(z**2)) < 1.3
    assert np.nanmax(np.abs(z)) < 5.0
    d = diagnose(arm, meas, advise=False)
    assert [s.key for s in d.suggested] == ["mount_compliance@M2"]
    assert d.ranking[0].fit.estimate(0) == pytest.approx(k, rel=0.05)


def test_rehearsal_records_of_an_arm_with_friction_keep_its_memory(tmp_path: Path) -> None:
    """A hidden joint friction: the rehearsal records follow the load cycle as one sequence
    (eodarm.solve_sequence), so the arm does not come back at the final 0 kg, and the file
    that records writes holds that loop within its stated errors."""
    arm = ARMS["seed-like"]()
    hidden = [eodarm.Effect("joint_friction", "O2", torque_nmm=20000.0)]
    alpha = solvable_configs(arm, 2, hidden)
    recs = synth_records(arm, alpha, SEQUENCE, hidden=hidden, seed=5)
    camp = write_synth_campaign(tmp_path / "rehearsal", recs)
    out = tmp_path / "meas.csv"
    assert main(["records", str(camp), "-o", str(out)]) == 0
    meas = read_measurements(out, arm.n)
    seq = eodarm.solve_sequence(arm, alpha, SEQUENCE[1:], effects=hidden)
    truth = np.concatenate(
        [
            channel_values({k: v[q] for k, v in seq.items()}, meas.channels)
            for q in range(len(alpha))
        ]
    )
    z = (meas.values - truth) / meas.sigma
    assert np.nanmax(np.abs(z)) < 5.0
    # what friction leaves at the return is real and seen: far beyond its error, and not
    # what a single loading of 0 kg would say (nothing)
    back = np.asarray(meas.mass_kg) == 0.0
    col = meas.channels.index("dy_mm")
    left = seq["dy_mm"][:, -1]
    assert np.all(np.abs(left) > 10 * meas.sigma[back, col])
    assert np.allclose(meas.values[back, col], left, atol=5 * meas.sigma[back, col].max())


# ---------------------------------------------------------------------- the command
@pytest.fixture(scope="module")
def campaign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("campaign")
    code = main(
        [
            "synth",
            "--arm",
            str(EXAMPLE),
            "--records",
            str(d),
            "--configs",
            "2",
            "--seed",
            "4",
            "--hidden",
            "mount_compliance@M2=3000",
        ]
    )
    assert code == 0
    return d / "campaign.toml"


def copy_campaign(src: Path, dst: Path) -> Path:
    dst.mkdir(parents=True, exist_ok=True)
    for f in src.parent.iterdir():
        if f.is_file():
            (dst / f.name).write_bytes(f.read_bytes())
    return dst / src.name


def refused(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err  # one line
    return err


def test_json_gives_every_state_of_every_record(
    campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    capsys.readouterr()
    assert main(["records", str(campaign), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [r["config"] for r in doc["records"]] == ["c1", "c2"]
    for r in doc["records"]:
        assert [s["mass_kg"] for s in r["states"]] == SEQUENCE
        for s in r["states"]:
            assert s["end_s"] - s["start_s"] > 5.0  # each state is held 7–10 s
            assert set(s["mean"]) == set(s["stderr"]) == set(s["drift_per_s"])
            assert s["drift"] is False
        starts = [s["start_s"] for s in r["states"]]
        assert starts == sorted(starts)


def test_a_drifting_state_is_refused_in_one_line_and_kept_with_allow_drift(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    d = tmp_path / "drift"
    assert (
        main(
            [
                "synth",
                "--arm",
                str(EXAMPLE),
                "--records",
                str(d),
                "--configs",
                "1",
                "--drift",
                "3=0.5",
            ]
        )
        == 0
    )
    out = tmp_path / "meas.csv"
    err = refused(["records", str(d / "campaign.toml"), "-o", str(out)], capsys)
    assert "c1.csv" in err and "drifts" in err and "6.5 kg" in err and " s " in err
    assert not out.exists()
    assert (
        main(["records", str(d / "campaign.toml"), "-o", str(out), "--allow-drift", "--json"]) == 0
    )
    doc = json.loads(capsys.readouterr().out)
    assert [s["drift"] for s in doc["records"][0]["states"]] == [False] * 3 + [True] + [False] * 3
    assert out.exists()


@pytest.mark.parametrize(
    ("masses", "says"),
    [
        ("[0.0, 1.5, 3.0, 5.0,", "found 7 steady states (at 0."),  # the operator skipped 3 kg
        ("[0.0, 5.0,", "found 7 steady states (at 0."),  # a state more than the payloads
    ],
)
def test_a_skipped_payload_is_refused(
    masses: str, says: str, campaign: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    c = copy_campaign(campaign, tmp_path / "skip")
    text = c.read_text().replace("[0.0, 1.5, 5.0,", masses, 1)
    c.write_text(text)
    out = tmp_path / "meas.csv"
    err = refused(["records", str(c), "-o", str(out)], capsys)
    n = masses.count(",") + 4  # payloads: the replaced start, then 6.5, 5, 1.5, 0
    assert "c1.csv" in err and says in err and f"the {n} payloads" in err
    assert ("fewer" if n > 7 else "more") in err
    assert not out.exists()


def _edit_record(path: Path, edit: object) -> None:
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join(edit(lines)))  # type: ignore[operator]


def _cell(line: str, col: int, text: str) -> str:
    cells = line.rstrip("\n").split(",")
    cells[col] = text
    return ",".join(cells) + "\n"


MALFORMED = {
    "time does not increase": lambda L: [*L[:500], L[501], L[500], *L[502:]],
    "is not a number": lambda L: [*L[:700], _cell(L[700], 2, "abc"), *L[701:]],
    "missing (empty cell)": lambda L: [*L[:900], _cell(L[900], 3, ""), *L[901:]],
    "unknown channel 'dz_mm'": lambda L: [L[0].replace("dy_mm", "dz_mm"), *L[1:]],
    "no 'time_s' column": lambda L: [L[0].replace("time_s", "t"), *L[1:]],
    "empty record": lambda L: L[:1],
    "truncated": lambda L: [*L[:-1], L[-1][: len(L[-1]) // 2]],
}


@pytest.mark.parametrize("what", list(MALFORMED))
def test_a_malformed_record_is_refused_in_one_line(
    what: str, campaign: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    c = copy_campaign(campaign, tmp_path / "bad")
    _edit_record(c.parent / "c2.csv", MALFORMED[what])
    out = tmp_path / "meas.csv"
    err = refused(["records", str(c), "-o", str(out)], capsys)
    assert "c2.csv" in err and what in err, err
    if what not in ("unknown channel 'dz_mm'", "no 'time_s' column", "empty record"):
        assert "line " in err and "time " in err  # the line and the time of the bad sample
    assert not out.exists()


def test_the_analysis_commands_take_a_campaign_and_say_so(
    campaign: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    capsys.readouterr()
    assert main(["diagnose", str(campaign), "--arm", str(EXAMPLE), "--json"]) == 0
    cap = capsys.readouterr()
    assert json.loads(cap.out)["suggested"] == ["mount_compliance@M2"]
    assert "is a campaign: ran `eodarm records`" in " ".join(cap.err.split())  # as wrapped
    assert (
        main(
            ["fit", str(campaign), "--arm", str(EXAMPLE), "--add", "mount_compliance@M2", "--json"]
        )
        == 0
    )
    cap = capsys.readouterr()
    est = json.loads(cap.out)["effects"][0]
    assert est["estimate"]["stiffness_n_per_mm"] == pytest.approx(
        3000, abs=5 * est["stderr"]["stiffness_n_per_mm"]
    )
    assert "is a campaign" in " ".join(cap.err.split())  # as wrapped


def test_the_figure_shades_a_refused_state_red(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--plot draws the refused record, so that the user sees why: its drifting state red."""
    from matplotlib.colors import to_hex

    from eodarm.analysis.records import analyse_record
    from eodarm.data.records import read_campaign, read_record
    from eodarm.viz.records_plot import REFUSED, record_figure

    d = tmp_path / "drift"
    assert (
        main(
            [
                "synth",
                "--arm",
                str(EXAMPLE),
                "--records",
                str(d),
                "--configs",
                "1",
                "--drift",
                "2=0.5",
            ]
        )
        == 0
    )
    assert main(["records", str(d / "campaign.toml"), "--plot", str(tmp_path / "fig")]) == 2
    assert (tmp_path / "fig" / "record_c1.png").stat().st_size > 10_000
    camp = read_campaign(d / "campaign.toml")
    spec = camp.records[0]
    res = analyse_record(read_record(spec.file, camp.n), spec)
    fig = record_figure(read_record(spec.file, camp.n), res)
    spans = [p for p in fig.axes[0].patches]
    red = [i for i, p in enumerate(spans) if to_hex(p.get_facecolor()[:3]) == REFUSED]
    assert red == [2]  # the state at 5 kg, the second after the reference


def test_the_report_on_a_campaign_shows_the_records_in_an_appendix(
    campaign: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "report.html"
    assert (
        main(["report", str(campaign), "--arm", str(EXAMPLE), "-o", str(out), "--rounds", "1"]) == 0
    )
    assert "is a campaign" in capsys.readouterr().err
    page = out.read_text()
    appendix = page[page.index("Appendix: the raw records") :]
    assert appendix.count("data:image/png;base64,") == 2  # one figure per record
    assert "c1 (c1.csv)" in appendix and "c2 (c2.csv)" in appendix


def test_the_written_rows_are_the_states_after_the_reference_in_order(
    campaign: Path, tmp_path: Path
) -> None:
    import csv

    out = tmp_path / "meas.csv"
    assert main(["records", str(campaign), "-o", str(out)]) == 0
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    for cfg in ("c1", "c2"):
        mine = [r for r in rows if r["config"] == cfg]
        assert [int(r["step"]) for r in mine] == [1, 2, 3, 4, 5, 6]
        assert [float(r["mass_kg"]) for r in mine] == SEQUENCE[1:]
        # the return to 0 kg: nothing in this arm has memory, so it comes back to the reference
        last = mine[-1]
        assert abs(float(last["dy_mm"])) < 5 * float(last["sigma_dy_mm"])


HEAD = '[[record]]\nfile = "a.csv"\nconfig = "c1"\n'
TWO = "alpha_deg = [1.0]\nmasses_kg = [0.0, 1.0]\n"
BAD_CAMPAIGNS = [
    ("", "no [[record]] table"),
    (HEAD + "alpha_deg = [1.0, 2.0]\n", "record 1: missing key 'masses_kg'"),
    (HEAD + "alpha_deg = [1.0]\nmasses_kg = [0.0]\n", "the reference and at least one payload"),
    (HEAD + "alpha_deg = [1.0]\nmasses_kg = [0.0, -1.0]\n", "negative payload"),
    (
        HEAD + TWO + '[[record]]\nfile = "b.csv"\nconfig = "c2"\n'
        "alpha_deg = [1.0, 2.0]\nmasses_kg = [0.0, 1.0]\n",
        "record 2: 'alpha_deg' has 2 angles",
    ),
]


@pytest.mark.parametrize(("text", "says"), BAD_CAMPAIGNS)
def test_a_bad_campaign_file_is_refused_in_one_line(
    text: str, says: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    c = tmp_path / "campaign.toml"
    c.write_text(text)
    err = refused(["records", str(c), "-o", str(tmp_path / "m.csv")], capsys)
    assert "campaign.toml" in err and says in err
