"""What the screen says about a suggested effect: never "does not help" beside "suggested", and
a look-alike shown on the verdict's own line (issue 28, item 1).

* A soft body of actuator 4 seen by a laser tracker alone (dx, dy) moves the arm exactly as a
  soft mount of actuator 4 does: the diagnosis suggests the mount (the tie order prefers what
  does not overrule the arm file), and must say on the verdict's line, in the JSON
  (``alternatives``) and in the report that the body fits as well, and that actuator 4's
  own sensor would tell them apart.
* A joint friction in a load cycle does not help alone (fitted alone it stays at zero) but
  is half of the suggested set: it is ranked with its value in the set, not listed among the
  candidates that do not help.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import eodarm
from arms import example_arm, four_link_arm
from eodarm.analysis.synth import random_configs, synth
from eodarm.cli import main

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
E = eodarm.Effect
MASSES = [1.5, 5.0, 6.5]
#: Actuator 4's body at half the arm file's 2000 N/mm, and a clearance at O2.
TRACKER_HIDDEN = [
    E("actuator_compliance", "M4", stiffness_n_per_mm=1000.0),
    E("joint_clearance", "O2", clearance_mm=0.15),
]


def _tracker(channels: list[str]) -> eodarm.Measurements:
    """Five poses of the 4-link arm, the hidden soft body and clearance."""
    arm = four_link_arm()
    cfg = random_configs(arm, 5, np.random.default_rng(7))
    return synth(arm, cfg, MASSES, TRACKER_HIDDEN, channels=channels, seed=2)


@pytest.fixture(scope="module")
def tracker_files(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("tracker")
    arm = d / "four.toml"
    arm.write_text(four_link_arm().to_toml(), encoding="utf-8")
    csv = d / "tracker.csv"
    _tracker(["dx_mm", "dy_mm"]).to_csv(csv)
    return arm, csv


def _soft(d: eodarm.Diagnosis) -> tuple[str, str]:
    """The suggested one of actuator 4's mount and body, and the other."""
    [member] = [s.spec for s in d.suggested if s.at == "M4"]
    other = ({"mount_compliance@M4", "actuator_compliance@M4"} - {member}).pop()
    return member, other


def test_a_look_alike_of_a_suggested_effect_is_named_with_its_value() -> None:
    """One of actuator 4's mount and body is suggested, the other is its alternative, and the
    set with the body (suggested or refitted in the mount's place) recovers the hidden
    1000 N/mm."""
    arm = four_link_arm()
    d = eodarm.diagnose(arm, _tracker(["dx_mm", "dy_mm"]))
    assert d.verdict == "missing"
    member, other = _soft(d)
    assert {s.spec for s in d.suggested} == {member, "joint_clearance@O2"}
    assert d.alternatives == {member: [other], "joint_clearance@O2": []}
    refit = d.alternative_fits[(member, other)]
    assert refit.chi2 - d.suggested_fit.chi2 < 3.84  # type: ignore[union-attr]
    body = d.suggested_fit if member.startswith("actuator") else refit
    assert body is not None
    j = [s.spec for s in body.slots].index("actuator_compliance@M4")
    assert abs(body.estimate(j) - 1000.0) < 2.0 * body.stderr(j) + 1.0
    [entry] = [a for a in d.advice if a["pair"] == [member, other]]
    assert entry["suggested"] and entry["channel"]["channel"] == "dl4_mm"


def test_with_the_actuators_own_sensor_there_is_no_look_alike() -> None:
    """dl4 measured: the body is found directly, and nothing is said to look like it."""
    d = eodarm.diagnose(four_link_arm(), _tracker(["dx_mm", "dy_mm", "dl4_mm"]), advise=False)
    assert d.verdict == "missing"
    assert {s.spec for s in d.suggested} == {"actuator_compliance@M4", "joint_clearance@O2"}
    assert not any(d.alternatives.values())
    assert d.to_json()["alternatives"] == {}


def test_the_verdict_line_and_the_json_name_the_look_alike(
    tracker_files: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    arm, csv = tracker_files
    assert main(["diagnose", str(csv), "--arm", str(arm), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    member = doc["suggested"][0]
    other = ({"mount_compliance@M4", "actuator_compliance@M4"} - {member}).pop()
    assert doc["suggested"] == [member, "joint_clearance@O2"]
    assert doc["alternatives"] == {member: [other]}
    assert main(["diagnose", str(csv), "--arm", str(arm)]) == 0
    out = capsys.readouterr().out
    verdict = " ".join(out.split("verdict:", 1)[1].split(" candidate sets searched", 1)[0].split())
    assert verdict.startswith(
        f"MISSING — suggested: {member} (or {other}: the data cannot tell them apart; a dl4_mm "
        "sensor would) + joint_clearance@O2 ("
    )
    # under the fitted effect, its look-alike's value in the set, marked as fitting as well
    assert any(ln.strip().startswith("or ") and f"({other})" in ln for ln in out.splitlines())


def test_the_report_shows_the_look_alike_on_its_first_screen(
    tracker_files: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    arm, csv = tracker_files
    out = tmp_path / "report.html"
    assert main(["report", str(csv), "--arm", str(arm), "-o", str(out)]) == 0
    said = capsys.readouterr().out
    line = next(ln for ln in said.splitlines() if ln.startswith("look-alike: "))
    member, other = line.split()[1], line.split()[6]
    assert {member, other} == {"mount_compliance@M4", "actuator_compliance@M4"}
    page = out.read_text(encoding="utf-8")
    answer = page.split("<h2>The answer</h2>", 1)[1].split("<h3>What is left</h3>", 1)[0]
    assert "Look-alike:" in answer and other in answer
    assert "a dl4_mm sensor would" in answer
    params = page.split("<h2>The fitted parameters</h2>", 1)[1].split("</table>", 1)[0]
    assert f"LOOK-ALIKE: could as well be {other}" in params


# ---------------------------------------------------------------------------- alone
@pytest.fixture(scope="module")
def cycle_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A load cycle whose friction does not help alone but is half of the answer."""
    arm = example_arm()
    cfg = random_configs(arm, 6, np.random.default_rng(5))
    hidden = [
        E("mount_compliance", "M1", stiffness_n_per_mm=2500.0),
        E("joint_friction", "O2", torque_nmm=3000.0),
    ]
    meas = synth(arm, cfg, [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0], hidden, seed=0, sequence=True)
    csv = tmp_path_factory.mktemp("cycle") / "cycle.csv"
    meas.to_csv(csv)
    return csv


def test_a_suggested_effect_is_never_among_those_that_do_not_help(
    cycle_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["diagnose", str(cycle_file), "--arm", str(EXAMPLE), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["suggested"] == ["mount_compliance@M1", "joint_friction@O2"]
    alone = next(c for c in doc["ranking"] if (c["effect"], c["at"]) == ("joint_friction", "O2"))
    assert alone["estimate"]["torque_nmm"] == 0.0  # alone, it fits to nothing: the point
    assert main(["diagnose", str(cycle_file), "--arm", str(EXAMPLE)]) == 0
    out = " ".join(capsys.readouterr().out.split())
    idle = out.split("do not help alone", 1)[1]
    assert "joint_friction@O2" not in idle
    assert "do not help (" not in out  # every such line says "alone"
    line = out.split("joint_friction@O2 does not help alone; ", 1)[1]
    said = line.removeprefix("with the rest of the suggested set it is ").split(" N·mm")[0]
    est, err = (float(x) for x in said.split(" ± "))
    assert abs(est - 3000.0) < 2.0 * err  # the hidden friction, within 2 standard errors


def test_the_report_ranks_a_suggested_effect_with_its_value_in_the_set(
    cycle_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "report.html"
    assert main(["report", str(cycle_file), "--arm", str(EXAMPLE), "-o", str(out)]) == 0
    capsys.readouterr()
    page = out.read_text(encoding="utf-8")
    ranking = page.split("Every candidate added alone", 1)[1].split("</table>", 1)[0]
    row = next(r for r in ranking.split("<tr") if "joint_friction@O2</td>" in r)
    assert "in the suggested set (alone: 0 N·mm (at bound))" in row
    said = row.split("torque_nmm = ", 1)[1].split(" N·mm")[0]
    est, err = (float(x) for x in said.split(" ± "))
    assert abs(est - 3000.0) < 2.0 * err  # its value in the set: the hidden friction
