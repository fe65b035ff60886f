"""The model named everywhere: an arm file's ``[[effect]]`` tables are part of "the model" in
every command's header and JSON ``model`` key (the file's effects, then the ``--add`` ones)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

import eodarm
from eodarm.cli import main
from eodarm.model.arm import FitRecord

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
MOUNT = eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=1512.0)
CLEAR = eodarm.Effect("joint_clearance", "O3", clearance_mm=0.15)


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """A fitted arm file (two effects in it) and measurements of that model."""
    from eodarm.analysis.synth import random_configs, synth

    arm = eodarm.Arm.from_toml(EXAMPLE)
    d = tmp_path_factory.mktemp("named")
    alpha = random_configs(arm, 6, np.random.default_rng(3))
    synth(arm, alpha, [1.5, 6.5], hidden=[MOUNT, CLEAR], seed=3).to_csv(d / "m.csv")
    rec = FitRecord(
        ("mount_compliance@M2:stiffness_n_per_mm", "joint_clearance@O3:clearance_mm"),
        ((1225.0, 0.0), (0.0, 4e-6)),
    )
    fitted = arm.with_effects([MOUNT, CLEAR], [35.0, 0.002], fit=rec)
    (d / "fitted.toml").write_text(fitted.to_toml())
    return {"meas": str(d / "m.csv"), "arm": str(d / "fitted.toml")}


def _run(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[str, str]:
    assert main(args) == 0
    cap = capsys.readouterr()
    return cap.out, cap.err


COMMANDS = {
    "solve": ["solve", "--alpha", "90,10,0", "--mass", "5"],
    "compensate": ["compensate", "--alpha", "90,10,0", "--mass", "5"],
    "compare": ["compare", "MEAS"],
    "diagnose": ["diagnose", "MEAS", "--max-set", "1"],
    "fit": ["fit", "MEAS", "--add", "base_compliance@base"],
}


@pytest.mark.parametrize("name", list(COMMANDS))
def test_every_header_names_the_arm_files_effects(
    name: str, files: dict[str, str], capsys: pytest.CaptureFixture[str]
) -> None:
    args = [files["meas"] if a == "MEAS" else a for a in COMMANDS[name]]
    out, err = _run([*args, "--arm", files["arm"]], capsys)
    text = " ".join((out + err).split())  # the header wraps at 100 columns
    want = "model: baseline + mount_compliance@M2, joint_clearance@O3 (arm file)"
    assert want in text
    # no header ends at the baseline (one that wraps before the file's effects goes on)
    assert re.search(r"model: baseline\n(?!\s+\+ )", out + err) is None
    if name == "diagnose":  # the fit before any candidate is this model, not the baseline
        assert "this model: χ²/dof" in text and "baseline: χ²/dof" not in text


@pytest.mark.parametrize("name", ["solve", "compare", "diagnose"])  # fit, compensate: no model key
def test_the_json_model_lists_the_files_effects_then_the_added_ones(
    name: str, files: dict[str, str], capsys: pytest.CaptureFixture[str]
) -> None:
    args = [files["meas"] if a == "MEAS" else a for a in COMMANDS[name]]
    out, _ = _run([*args, "--arm", files["arm"], "--json"], capsys)
    doc = json.loads(out)
    assert doc["model"] == ["mount_compliance@M2", "joint_clearance@O3"]


def test_an_added_effect_replaces_the_files_at_the_same_place_in_the_model(
    files: dict[str, str], capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["compare", files["meas"], "--arm", files["arm"], "--add", "mount_compliance@M2"]
    out, err = _run(args, capsys)
    assert "model: baseline + joint_clearance@O3 (arm file) + mount_compliance@M2" in " ".join(
        (out + err).split()
    )
    out, _ = _run([*args, "--json"], capsys)
    assert json.loads(out)["model"] == ["joint_clearance@O3", "mount_compliance@M2"]


def test_the_reports_model_words_name_the_arm_files_effects(files: dict[str, str]) -> None:
    from eodarm.analysis.fit import compare, fit
    from eodarm.data.reader import read_measurements
    from eodarm.viz.report_summary import model_words

    arm = eodarm.Arm.from_toml(files["arm"])
    meas = read_measurements(files["meas"], arm.n)
    assert model_words(compare(arm, meas)) == (
        "baseline + actuator 2 mount, joint O3 clearance (arm file)"
    )
    refit = fit(arm, meas, ["mount_compliance@M2"])
    assert model_words(refit) == "baseline + joint O3 clearance (arm file) + actuator 2 mount"


FORMATS = Path(__file__).resolve().parents[1] / "docs" / "formats.md"


@pytest.mark.parametrize("name", list(COMMANDS))
def test_docs_formats_describes_every_json_key_a_command_prints(
    name: str, files: dict[str, str], capsys: pytest.CaptureFixture[str]
) -> None:
    """docs/formats.md §7 names every key of every command's JSON (top level and per pose)."""
    args = [files["meas"] if a == "MEAS" else a for a in COMMANDS[name]]
    extra = ["--uncertainty"] if name == "solve" else []
    if name == "fit":
        args += ["--cv", "config"]
    out, _ = _run([*args, "--arm", files["arm"], "--json", *extra], capsys)
    doc = json.loads(out)
    keys = set(doc) | {k for p in doc.get("poses", []) for k in p}
    text = FORMATS.read_text(encoding="utf-8")
    section = text[text.index(f"### `eodarm {name} --json`") :]
    section = section[: section.index("\n### ", 1)]
    missing = sorted(k for k in keys if f'"{k}"' not in section and f"`{k}`" not in section)
    assert not missing, f"docs/formats.md, {name} --json: {missing} not described"
