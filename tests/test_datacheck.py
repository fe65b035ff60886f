"""The lab's mistakes named, not blamed on physics (issue 27 item 3).

Before any verdict the data are held against the baseline model's scale and sign. Each
mistake is built in the test from honest synthetic data, as a lab would make it: metres (or
microns) in an ``_mm`` column, a channel with its sign flipped, load sequences zeroed with
the first payload on. ``diagnose`` then says to check the data (verdict ``check_data``, one
line per mistake with its fix), ``compare`` and ``fit`` say it too and ``fit`` never calls
such data explained. On honest data, every effect of the catalogue hidden, nothing fires and
no verdict changes. Grams are caught on the command line, in campaign files (``masses_kg``)
and in arm files, a file with no
measured value is refused, and ``fit`` takes the very model that made ``synth``'s data.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import eodarm
from arms import example_arm, four_link_arm, seed_like_arm, two_link_arm
from eodarm.analysis.datacheck import check_data
from eodarm.analysis.diagnose import diagnose
from eodarm.analysis.synth import random_configs, synth
from eodarm.cli import main
from eodarm.data.datasets import bundled_arm_path
from eodarm.data.measurements import MeasurementFileError, Measurements
from eodarm.data.reader import read_measurements
from eodarm.errors import MAX_MESSAGE

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
CYCLE = [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0]


def cli(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    capsys.readouterr()
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def honest(tmp_path: Path, *, sequence: bool = False, channels: str = "dx_mm,dy_mm,dl") -> Path:
    """Synthetic measurements of the example arm, nothing hidden, written as a file."""
    arm = eodarm.Arm.from_toml(EXAMPLE)
    alpha = random_configs(arm, 8, 11)
    masses = CYCLE if sequence else [1.5, 5.0, 6.5]
    meas = synth(arm, alpha, masses, channels=channels, sequence=sequence, seed=3)
    path = tmp_path / ("cycles.csv" if sequence else "honest.csv")
    meas.to_csv(path)
    return path


def edited(path: Path, name: str, fn: Callable[[Measurements], np.ndarray]) -> Path:
    """A copy of a measurement file whose values are ``fn(meas)`` (σ and the rest kept)."""
    meas = read_measurements(path, 3)
    values = fn(meas)
    out = Measurements.from_arrays(
        meas.config,
        meas.alpha_deg,
        meas.mass_kg,
        {ch: values[:, meas.index(ch)] for ch in meas.measured_channels},
        {ch: meas.sigma[:, meas.index(ch)] for ch in meas.measured_channels},
        step=meas.step,
    )
    target = path.with_name(name)
    out.to_csv(target)
    return target


def scaled(channel: str, factor: float) -> Callable[[Measurements], np.ndarray]:
    def fn(meas: Measurements) -> np.ndarray:
        v = meas.values.copy()
        v[:, meas.index(channel)] *= factor
        return v

    return fn


def in_grams(meas: Measurements) -> Measurements:
    """The same measurements with every ``mass_kg`` written in grams."""
    return Measurements.from_arrays(
        meas.config,
        meas.alpha_deg,
        meas.mass_kg * 1000.0,
        {ch: meas.values[:, meas.index(ch)] for ch in meas.channels},
        {ch: meas.sigma[:, meas.index(ch)] for ch in meas.channels},
    )


def zeroed(meas: Measurements) -> np.ndarray:
    """Every sequence read relative to its first loaded state (sensors zeroed there)."""
    v = meas.values.copy()
    for rows in meas.sequences():
        v[rows] = v[rows] - v[rows[0]]
    return v


MISTAKES = [
    ("metres.csv", scaled("dy_mm", 1e-3), "dy_mm", "scale", ["metres", "multiply it by 1000"]),
    ("microns.csv", scaled("dl2_mm", 1e3), "dl2_mm", "scale", ["microns", "divide it by 1000"]),
    ("flipped.csv", scaled("dy_mm", -1.0), "dy_mm", "sign", ["sign-flipped", "sag is negative"]),
    ("dx.csv", scaled("dx_mm", -1.0), "dx_mm", "sign", ["sign-flipped", "change its sign"]),
]


@pytest.mark.parametrize(("name", "fn", "channel", "problem", "words"), MISTAKES)
def test_a_unit_or_sign_mistake_is_named_not_called_unexplained(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    name: str,
    fn: Callable[[Measurements], np.ndarray],
    channel: str,
    problem: str,
    words: list[str],
) -> None:
    """Before: "UNEXPLAINED — not in the catalogue" (the sign flip with a best effort of
    "± 0 N"). Now the verdict says to check the data, naming the channel, what it looks
    like and the fix."""
    path = edited(honest(tmp_path), name, fn)
    code, out, _ = cli(capsys, "diagnose", path, "--arm", EXAMPLE, "--json")
    doc = json.loads(out)
    assert code == 0 and doc["verdict"] == "check_data" and doc["suggested"] == []
    assert "best_effort" not in doc and doc["ranking"] == []
    (check,) = doc["data_checks"]
    assert check["channel"] == channel and check["problem"] == problem
    assert all(w in check["message"] for w in words)
    assert len("eodarm: " + check["message"]) < MAX_MESSAGE
    code, out, _ = cli(capsys, "diagnose", path, "--arm", EXAMPLE)
    assert "verdict: CHECK THE DATA" in out and "UNEXPLAINED" not in out and "± 0" not in out
    assert words[0] in out


def test_sequences_zeroed_with_the_first_payload_on_are_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = edited(honest(tmp_path, sequence=True), "zeroed.csv", zeroed)
    code, out, _ = cli(capsys, "diagnose", path, "--arm", EXAMPLE, "--json")
    doc = json.loads(out)
    assert code == 0 and doc["verdict"] == "check_data"
    (check,) = doc["data_checks"]
    assert check["problem"] == "zeroed" and check["channel"] is None
    assert check["configs"] == [f"c{i}" for i in range(1, 9)]
    assert check["message"].startswith("sequences c1, c2, c3 and 5 more look zeroed")
    assert "zero the sensors unloaded" in check["message"]


def test_compare_and_fit_say_it_and_fit_never_calls_mistaken_data_explained(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A fit can explain data 1000 times too small by pushing a body to rigid (dl reads
    nearly nothing): ``[fit] explained`` stays false on data that look mistaken."""
    path = edited(honest(tmp_path, channels="dl"), "dl_metres.csv", scaled("dl1_mm", 1e-3))
    code, out, err = cli(capsys, "compare", path, "--arm", EXAMPLE, "--json")
    assert code == 0 and json.loads(out)["data_checks"][0]["channel"] == "dl1_mm"
    assert "check the data: dl1_mm looks like metres" in " ".join(err.split())
    fitted = tmp_path / "fitted.toml"
    argv = ["fit", path, "--arm", EXAMPLE, "--add", "actuator_compliance@M1", "-o", fitted]
    code, out, err = cli(capsys, *argv, "--json")
    doc = json.loads(out)
    assert code == 0 and doc["data_checks"][0]["problem"] == "scale"
    assert doc["after"]["chi2_per_dof"] < 2.0  # the rigid body "explains" them …
    assert doc["fitted_file"]["explained"] is False  # … but they are not called explained
    assert eodarm.Arm.from_toml(fitted).fit.explained is False
    assert "check the data" in err


def test_a_file_with_no_measured_value_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """It passed compare, and fit wrote an arm with explained = true and χ²/dof 0."""
    path = tmp_path / "nothing.csv"
    path.write_text(
        "config,alpha1_deg,alpha2_deg,alpha3_deg,mass_kg,dy_mm\nc1,90,10,0,1.5,\nc1,90,10,0,5,\n"
    )
    for argv in (["compare"], ["fit", "--add", "mount_compliance@M2", "-o", tmp_path / "f.toml"]):
        code, _, err = cli(capsys, argv[0], path, "--arm", EXAMPLE, *argv[1:])
        assert code == 2 and err.count("\n") == 1
        assert f"{path}: no measured value: every cell of dy_mm is empty" in err
    assert not (tmp_path / "f.toml").exists()
    with pytest.raises(MeasurementFileError, match="no channel column"):
        read_measurements(_write(tmp_path, "config,alpha1_deg,alpha2_deg,alpha3_deg,mass_kg\n"), 3)


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "header_only.csv"
    path.write_text(text + "c1,90,10,0,1.5\n")
    return path


# ------------------------------------------------------------------ no false alarms
def _catalogue(arm: eodarm.Arm) -> list[eodarm.Effect]:
    """Every effect of the catalogue at every place, at two sizes each (a body both softer
    and forty times stiffer than its file: the seed arm's are)."""
    out = [eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=v) for v in (6e7, 1e7)]
    for i in range(1, arm.n + 1):
        k = arm.actuators[i - 1].stiffness_n_per_mm
        out += [
            eodarm.Effect("actuator_compliance", f"M{i}", stiffness_n_per_mm=k * f)
            for f in (0.3, 40.0)
        ]
        out += [
            eodarm.Effect("mount_compliance", f"M{i}", stiffness_n_per_mm=v) for v in (1500, 300)
        ]
        out += [eodarm.Effect("actuator_play", f"M{i}", play_mm=v) for v in (0.05, 0.3)]
        out += [eodarm.Effect("joint_clearance", f"O{i}", clearance_mm=v) for v in (0.1, 0.5)]
        out += [eodarm.Effect("link_bending", f"L{i}", ei_n_mm2=v) for v in (5e8, 5e7)]
        out += [eodarm.Effect("actuator_friction", f"M{i}", friction_n=v) for v in (20, 200)]
        out += [eodarm.Effect("joint_friction", f"O{i}", torque_nmm=v) for v in (2e3, 2e4)]
    return out


@pytest.mark.parametrize("arm_of", [example_arm, seed_like_arm, two_link_arm, four_link_arm])
@pytest.mark.parametrize("sequence", [False, True])
def test_no_check_fires_on_honest_data_whatever_effect_is_hidden(
    arm_of: Callable[[], eodarm.Arm], sequence: bool
) -> None:
    """Every catalogue effect hidden, alone, on four arms, with and without load cycles, on
    three selections of channels: the model is wrong (often by a factor of several), the
    data are not mistaken, and nothing fires."""
    arm = arm_of()
    alpha = random_configs(arm, 8, 2)
    masses = CYCLE if sequence else [1.5, 5.0, 6.5]
    fired = []
    for k, effect in enumerate(_catalogue(arm)):
        for channels in ("all", "dy_mm", "dl"):
            meas = synth(arm, alpha, masses, [effect], channels, sequence=sequence, seed=k)
            fired += [(effect, channels, c.message) for c in check_data(arm, meas)]
    assert fired == []


def test_a_friction_that_holds_the_first_payload_is_not_called_zeroed() -> None:
    """Joint frictions at every joint that hold the whole first payload: its state reads 0
    within the noise on every channel, as a zeroed one would. On a loading branch alone the
    two look alike (and the check stays silent: the reading is not exactly 0); on a cycle the
    return tells them apart."""
    arm = example_arm()
    alpha = random_configs(arm, 8, 5)
    hidden = [eodarm.Effect("joint_friction", f"O{i + 1}", torque_nmm=1e4) for i in range(3)]
    for masses in (CYCLE, [0.0, 1.5, 5.0, 6.5], [0.0, 1.5, 3.0, 4.5, 6.5]):
        meas = synth(arm, alpha, masses, hidden, "all", sequence=True)
        first = meas.step == 1
        held = np.all(np.abs(meas.values[first] / meas.sigma[first]) <= 3.0, axis=1)
        assert held.any()  # the friction holds the first payload in some sequences
        assert check_data(arm, meas) == []


def test_the_seed_data_and_their_verdicts_are_not_touched() -> None:
    """The bundled seed data (real, and far from the 500 N/mm model: bodies 40 times
    stiffer) are not mistaken data; a diagnosis with hidden effects keeps its verdict."""
    arm = eodarm.Arm.from_toml(bundled_arm_path("seed2022"))
    meas = read_measurements(bundled_arm_path("seed2022").with_name("measurements.csv"), 3)
    assert check_data(arm, meas) == []
    ex = example_arm()
    hidden = [eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=1500.0)]
    data = synth(ex, random_configs(ex, 8, 1), [1.5, 5.0, 6.5], hidden, seed=1)
    d = diagnose(ex, data)
    assert d.verdict == "missing" and [s.key for s in d.suggested] == ["mount_compliance@M2"]
    assert d.data_checks == [] and d.to_json()["data_checks"] == []


# ------------------------------------------------------------------ grams and metres
@pytest.mark.parametrize(
    "argv",
    [
        ["solve", "--alpha", "90,10,0", "--mass", "5000"],
        ["compensate", "--alpha", "90,10,0", "--mass", "5000"],
        ["synth", "--masses", "1500,5000", "--configs", "2"],
        ["sweep", "--mass", "5000", "--alpha1", "80:100:3", "--alpha2", "10", "--alpha3", "0"],
        ["plan", "--configs", "2", "--pool", "40", "--sequence", "0,1500,5000,0"],
    ],
)
def test_a_payload_in_grams_on_the_command_line_gets_a_hint(
    capsys: pytest.CaptureFixture[str], argv: list[str]
) -> None:
    """``--mass 5000`` gave "row 0 … near_singular" (compensate) or a silent answer: the
    payload is over ten times the arm's own 10.1 kg and a thousandth of it is not. ``plan
    --sequence 0,1500,5000,0`` said only that no configuration keeps its states valid."""
    code, _, err = cli(capsys, *argv, "--arm", EXAMPLE)
    hint = "5000 kg is over 10 times the arm's own 10.1 kg: is it grams? (5 kg)"
    assert hint in " ".join(err.split())
    if code == 2:  # refused: the hint comes first in the one line
        flag = next(a for a in argv if a in ("--mass", "--masses", "--sequence"))
        assert err.count("\n") == 1 and err.startswith(f"eodarm: error: {flag}")


def test_a_payload_an_arm_can_carry_gets_no_hint(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = cli(capsys, "solve", "--arm", EXAMPLE, "--alpha", "90,10,0", "--mass", "50")
    assert code == 0 and "grams" not in err


@pytest.fixture(scope="module")
def rehearsal(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A rehearsal campaign of the example arm (``synth --records``), payloads in kg."""
    folder = tmp_path_factory.mktemp("rehearsal")
    argv = ["synth", "--arm", str(EXAMPLE), "--records", str(folder), "--configs", "2"]
    assert main([*argv, "--seed", "4"]) == 0
    return folder / "campaign.toml"


def campaign_copy(src: Path, dst: Path, factor: float) -> Path:
    """A copy of a campaign and its records whose ``masses_kg`` are multiplied by ``factor``."""
    dst.mkdir(parents=True)
    for f in src.parent.iterdir():
        (dst / f.name).write_bytes(f.read_bytes())
    text = src.read_text(encoding="utf-8")
    old = "masses_kg = [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0]"
    assert text.count(old) == 2  # synth's load cycle, in both records
    new = "masses_kg = [" + ", ".join(f"{m * factor:g}" for m in CYCLE) + "]"
    (dst / src.name).write_text(text.replace(old, new), encoding="utf-8")
    return dst / src.name


@pytest.mark.parametrize(
    ("with_arm", "words"),
    [
        (True, "6500 kg is over 10 times the arm's own 10.1 kg: is it grams? (6.5 kg)"),
        (False, "6500 kg is over 100 kg, more than an arm of this kind carries: is it grams? "
         "(6.5 kg)"),
    ],
)  # fmt: skip
def test_a_campaign_in_grams_gets_the_hint_naming_file_record_and_key(
    rehearsal: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    with_arm: bool,
    words: str,
) -> None:
    """``masses_kg = [0, 1500, 5000, 6500, …]`` passed ``records`` without a word (issue 27
    item 3). With ``--arm`` the arm's own mass gives the scale, as for ``--mass``; without
    it, a plain range (over 100 kg). A note, not a refusal: the states are written."""
    campaign_copy(rehearsal, tmp_path / "g", 1000.0)
    monkeypatch.chdir(tmp_path)
    campaign, out = Path("g", "campaign.toml"), Path("meas.csv")
    arm = ["--arm", EXAMPLE] if with_arm else []
    code, _, err = cli(capsys, "records", campaign, "-o", out, *arm)
    assert code == 0 and out.exists(), err
    text = " ".join(err.split())  # as wrapped
    line = f"{campaign}: record 1 ('c1') masses_kg[3] {words}; 1 other record over"
    assert line in text
    if not with_arm:
        assert "--arm ARM.toml checks it against the arm's own mass" in text
    (hint,) = [n for n in text.split("eodarm: ") if "masses_kg[3]" in n]
    assert len("eodarm: note: " + hint.strip()) < MAX_MESSAGE
    code, _, err = cli(capsys, "records", rehearsal, *arm, "--json")  # in kg: no word
    assert code == 0 and "masses_kg[" not in err and "grams" not in err
    deep = Path("x" * 150, "y" * 150)  # a long name is cut: the line stays short
    campaign_copy(rehearsal, deep, 1000.0)
    code, _, err = cli(capsys, "records", deep / "campaign.toml", *arm, "--json")
    (hint,) = [n for n in " ".join(err.split()).split("eodarm: ") if "masses_kg[3]" in n]
    assert len("eodarm: note: " + hint.strip()) < MAX_MESSAGE and "is it grams?" in hint


@pytest.mark.parametrize("command", ["compare", "diagnose"])
def test_a_campaign_in_grams_refused_by_the_arm_says_grams_first(
    rehearsal: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    command: str,
) -> None:
    """The example arm cannot take 5000 kg: given as the data of ``compare`` or
    ``diagnose``, the grams campaign is refused (``check_states``) in one line whose start
    names the campaign, the record and the key, and says what it looks like; the refusal
    follows (a short path, as a user types it, leaves it room)."""
    campaign_copy(rehearsal, tmp_path / "g", 1000.0)
    monkeypatch.chdir(tmp_path)
    campaign = Path("g", "campaign.toml")
    code, _, err = cli(capsys, command, campaign, "--arm", EXAMPLE)
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith(
        f"eodarm: error: {campaign}: record 1 ('c1') masses_kg[3] 6500 kg is over 10 times "
        "the arm's own 10.1 kg: is it grams? (6.5 kg);"
    )
    assert "cannot take" in err and len(err.rstrip("\n")) < MAX_MESSAGE


@pytest.mark.parametrize("command", ["compare", "diagnose", "fit"])
def test_a_measurement_file_in_grams_on_a_stiff_arm_gets_the_hint(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    """Actuators 100 times stiffer than the example's take 1500–6500 kg without failing to
    close: the door's refusal ("cannot close … in grams?") does not fire, the data read
    their noise where the model expects millimetres, and no channel check can say why. The
    heaviest line gets ``--mass``'s hint (it passed without a word)."""
    d = example_arm().to_dict()
    for act in d["actuator"]:
        act["stiffness_n_per_mm"] *= 100.0
    arm = eodarm.Arm.from_dict(d)
    arm_path = tmp_path / "stiff.toml"
    arm_path.write_text(arm.to_toml(), encoding="utf-8")
    alpha = random_configs(arm, 8, 3)
    meas = synth(arm, alpha, [1.5, 5.0, 6.5], seed=1)
    grams = in_grams(meas)
    closes = eodarm.solve(arm, grams.alpha_deg, grams.mass_kg)
    assert np.isfinite(np.asarray(closes["dy_mm"])).all()  # nothing for the door to refuse
    path = tmp_path / "grams.csv"
    grams.to_csv(path)
    extra = ["--add", "mount_compliance@M2"] if command == "fit" else []
    code, _, err = cli(capsys, command, path, "--arm", arm_path, *extra)
    assert code == 0, err
    heavy = 2 + int(np.argmax(grams.mass_kg))  # the first 6500 kg row's 1-based line
    line = (
        f"{path} line {heavy}: mass_kg 6500 kg is over 10 times the arm's own 10.1 kg: is it "
        "grams? (6.5 kg); 23 other lines over 101 kg too"
    )
    assert line in " ".join(err.split())
    meas.to_csv(tmp_path / "kg.csv")  # the same data in kilograms: no word
    code, _, err = cli(capsys, command, tmp_path / "kg.csv", "--arm", arm_path, *extra)
    assert code == 0 and "grams" not in err


def test_a_campaign_hint_follows_the_arms_scale() -> None:
    """The campaign's rule is ``payload_hint``'s: a heavy arm carries what a light one
    cannot, an arm without masses gives no scale, and a payload whose thousandth is still
    too heavy is not called grams."""
    from eodarm.data.plausible import campaign_payload_hint
    from eodarm.data.records import Campaign, RecordSpec

    def camp(*masses: float) -> Campaign:
        return Campaign(Path("c.toml"), (RecordSpec(Path("c1.csv"), "c1", (90.0, 10.0), masses),))

    light, heavy, massless = two_link_arm(), two_link_arm(), two_link_arm()
    d = heavy.to_dict()
    for part in (*d["link"], *d["actuator"]):
        part["mass_kg"] = 100.0 * part.get("mass_kg", 0.0) + 10.0
    heavy = eodarm.Arm.from_dict(d)
    d = massless.to_dict()
    for part in (*d["link"], *d["actuator"]):
        part["mass_kg"] = 0.0
    massless = eodarm.Arm.from_dict(d)
    limit = 10.0 * (sum(x.mass_kg for x in light.links) + sum(x.mass_kg for x in light.actuators))
    assert 1.0 < limit < 150.0
    assert campaign_payload_hint(camp(0.0, limit * 0.9), light) is None
    assert "is it grams?" in (campaign_payload_hint(camp(0.0, 150.0), light) or "")
    assert campaign_payload_hint(camp(0.0, 150.0), heavy) is None
    assert campaign_payload_hint(camp(0.0, 150.0), massless) is None
    assert "check its unit (kg)" in (campaign_payload_hint(camp(0.0, 5e5), light) or "")
    assert campaign_payload_hint(camp(0.0, 90.0)) is None  # no arm: the plain 100 kg
    assert "c.toml: record 1 ('c1') masses_kg[1] 150 kg" in (
        campaign_payload_hint(camp(0, 150.0)) or ""
    )


@pytest.mark.parametrize(
    ("edit", "words"),
    [
        (("mass_kg = 3.0", "mass_kg = 3000.0"), "link[1].mass_kg 3000 kg (over 217 kg"),
        (("mass_kg = 1.5", "mass_kg = 1500.0"), "actuator[1].mass_kg 1500 kg"),
        (("[480.0, 0.0]", "[0.48, 0.0]"), None),
    ],
)
def test_an_arm_file_in_grams_or_metres_gets_a_unit_hint(
    tmp_path: Path, edit: tuple[str, str], words: str | None
) -> None:
    text = EXAMPLE.read_text(encoding="utf-8")
    assert edit[0] in text
    path = tmp_path / "arm.toml"
    path.write_text(text.replace(edit[0], edit[1], 1), encoding="utf-8")
    if words is None:  # every length of the arm in metres
        text = path.read_text(encoding="utf-8")
        for a, b in (("[380.0, 0.0]", "[0.38, 0.0]"), ("[360.0, 0.0]", "[0.36, 0.0]")):
            text = text.replace(a, b, 1)
        path.write_text(text, encoding="utf-8")
        words = "the arm is 1.22 mm long in all (links 0.48, 0.38, 0.36 mm): are the lengths in"
    with pytest.warns(UserWarning) as caught:
        eodarm.Arm.from_toml(path)
    notes = [str(w.message) for w in caught]
    assert any(words in n for n in notes), notes
    assert all(len("eodarm: note: " + n) < MAX_MESSAGE for n in notes)


# ------------------------------------------------------------------ synth's own model
def test_fit_takes_the_model_that_made_synths_data(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A soft mount at M2 (800 N/mm) hidden in 600 states of the example arm: under it some
    states deflect beyond the model's validity (large_deflection). ``compare`` gives the
    generating model χ²/dof ≈ 1, and ``fit`` refused it ("the data do not support this
    model"); it now fits it, keeps those states and marks them."""
    arm = eodarm.Arm.from_toml(EXAMPLE)
    hidden = [eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=800.0)]
    alpha = random_configs(arm, 220, 4)
    out = eodarm.solve(arm, np.repeat(alpha, 3, axis=0), np.tile([1.5, 5, 6.5], 220), hidden)
    closes = np.isfinite(np.asarray(out["dy_mm"])).reshape(-1, 3).all(axis=1)
    alpha = alpha[closes][:200]  # the states that close under the soft mount (synth's rule)
    out = eodarm.solve(arm, np.repeat(alpha, 3, axis=0), np.tile([1.5, 5, 6.5], 200), hidden)
    outside = int((np.asarray(out["status"]) != 0).sum())
    assert outside > 0  # the generating model itself puts states outside its validity
    path = tmp_path / "synth.csv"
    synth(arm, alpha, [1.5, 5.0, 6.5], hidden, seed=2).to_csv(path)
    code, out, err = cli(
        capsys, "fit", path, "--arm", EXAMPLE, "--add", "mount_compliance@M2", "--json"
    )
    assert code == 0, err
    doc = json.loads(out)
    k = doc["effects"][0]["estimate"]["stiffness_n_per_mm"]
    assert abs(k - 800.0) < 4 * doc["effects"][0]["stderr"]["stiffness_n_per_mm"]
    assert 0.8 < doc["after"]["chi2_per_dof"] < 1.2
    mark = doc["outside_validity"]
    assert mark["states"] == outside and mark["of"] == 600 and not mark["before_fit"]
    assert "kept in the fit, the model is not trusted there" in " ".join(err.split())


def test_the_report_stops_at_the_first_round_and_says_to_check_the_data(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = edited(honest(tmp_path), "metres.csv", scaled("dy_mm", 1e-3))
    page = tmp_path / "report.html"
    code, out, err = cli(capsys, "report", path, "--arm", EXAMPLE, "-o", page)
    assert code == 0, err
    html = page.read_text(encoding="utf-8")
    assert '<span class="verdict check_data">check_data</span>' in html
    assert "Check the data first." in html and "dy_mm looks like metres" in html
    assert "last round (1): check_data" in out
    assert "check the data: dy_mm looks like metres" in " ".join(err.split())


def test_payloads_in_grams_are_named_not_every_channel_in_metres() -> None:
    """A stiff arm (bodies 10⁴ times the example's) closes even under 1000 times its
    payloads: masses written in grams make the model read 1000 times the data on every
    channel, the angles too. One check names the masses, not the channels."""
    d = example_arm().to_dict()
    for act in d["actuator"]:
        act["stiffness_n_per_mm"] *= 1e4
    arm = eodarm.Arm.from_dict(d)
    alpha = random_configs(arm, 8, 3)
    meas = synth(arm, alpha, [1.5, 5.0, 6.5], channels="all", noise=1e-3, seed=1)
    grams = in_grams(meas)
    (check,) = check_data(arm, grams)
    assert check.channel == "mass_kg" and check.problem == "scale"
    assert "mass_kg looks like grams" in check.message and "divide mass_kg by 1000" in check.message
    assert "is it grams? (6.5 kg)" in check.message
    assert len("eodarm: " + check.message) < MAX_MESSAGE
