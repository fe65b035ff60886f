"""The result of a load cycle is the return to zero load: the report says it on its first
screen, with the loops large enough to read (issue 28, item 2), and its numbers read one way
(item 4)."""

from __future__ import annotations

import base64
import io
import re
from pathlib import Path

import numpy as np
import pytest
from matplotlib.collections import LineCollection

import eodarm
from arms import example_arm
from eodarm.analysis.fit import compare, fit
from eodarm.analysis.synth import random_configs, synth
from eodarm.cli import main
from eodarm.viz.hysteresis import loops

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
E = eodarm.Effect
CYCLE = [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0]
HIDDEN = [
    E("mount_compliance", "M1", stiffness_n_per_mm=2500.0),
    E("joint_friction", "O2", torque_nmm=5000.0),
]


@pytest.fixture(scope="module")
def cycle() -> eodarm.Measurements:
    arm = example_arm()
    cfg = random_configs(arm, 5, np.random.default_rng(11))
    return synth(arm, cfg, CYCLE, HIDDEN, seed=4, sequence=True)


@pytest.fixture(scope="module")
def report(cycle: eodarm.Measurements, tmp_path_factory: pytest.TempPathFactory) -> tuple[str, str]:
    """The report's page and what `eodarm report` printed."""
    d = tmp_path_factory.mktemp("cycle_report")
    csv, out = d / "cycle.csv", d / "report.html"
    cycle.to_csv(csv)
    buf = io.StringIO()
    from contextlib import redirect_stdout

    with redirect_stdout(buf):
        assert main(["report", str(csv), "--arm", str(EXAMPLE), "-o", str(out)]) == 0
    return out.read_text(encoding="utf-8"), buf.getvalue()


def _worst_return(meas: eodarm.Measurements) -> tuple[str, float]:
    """The sequence whose measured dy at the return to 0 kg is furthest from 0, and that dy."""
    c = meas.index("dy_mm")
    last = [
        (str(meas.config[rows[-1]]), float(meas.values[rows[-1], c])) for rows in meas.sequences()
    ]
    return max(last, key=lambda t: abs(t[1]))


def test_the_return_to_zero_load_is_on_the_first_screen(
    cycle: eodarm.Measurements, report: tuple[str, str]
) -> None:
    page, _ = report
    answer = page.split("<h2>The answer</h2>", 1)[1].split("<h3>What is left</h3>", 1)[0]
    assert "<h3>The return to zero load</h3>" in answer
    config, dy = _worst_return(cycle)
    assert dy < -0.05  # the friction holds the arm low: well beyond the 0.02 mm noise
    words = " ".join(answer.split("<h3>The return to zero load</h3>", 1)[1].split())
    m = re.search(
        r"in sequence (\S+) the measure point stays ([\d.]+) mm below its reference", words
    )
    assert m, words[:400]
    assert m[1] == config
    assert float(m[2]) == pytest.approx(abs(dy), rel=5e-3)  # three significant digits


def test_the_loops_on_the_first_screen_are_drawn_large(report: tuple[str, str]) -> None:
    from PIL import Image

    page, _ = report
    block = page.split("<h3>The return to zero load</h3>", 1)[1].split("<h3>What is left</h3>")[0]
    [data] = re.findall(r'src="data:image/png;base64,([^"]+)" alt="hysteresis loops"', block)
    width, _ = Image.open(io.BytesIO(base64.b64decode(data))).size
    # 4.2 in per panel at 120 dpi: wider than the page's 1180 px column, so shown at full width
    assert width >= 1400
    assert '<div class="row"><div>' not in block  # not squeezed beside a table


def test_report_says_where_the_arm_comes_back_in_the_terminal(
    cycle: eodarm.Measurements, report: tuple[str, str]
) -> None:
    _, said = report
    config, dy = _worst_return(cycle)
    line = " ".join(said.split("return to 0 kg: ", 1)[1].split("\n")[0:2])
    assert line.startswith(f"the arm stays {abs(dy):.3g} mm below its reference in {config}")


def test_the_loops_draw_a_memoryless_baseline_dashed_once(cycle: eodarm.Measurements) -> None:
    """The baseline has no memory: its unloading branch is its loading branch. Drawn as one
    polyline there and back, the dashes of the two passes fill each other's gaps and it looks
    solid; each segment is drawn once, dashed."""
    arm = example_arm()
    base = compare(arm, cycle, [])
    after = fit(arm, cycle, ["mount_compliance@M1", "joint_friction@O2"])
    fig = loops(cycle, base, after)
    for ax in fig.axes:
        assert ax.get_ylabel() in ("", "dy [mm]")  # the channel's name and unit, once
        [dashed] = [
            c for c in ax.collections if isinstance(c, LineCollection) and c.get_gid() == "before"
        ]
        segs = [tuple(map(tuple, np.round(s, 9))) for s in dashed.get_segments()]
        undirected = {tuple(sorted(s)) for s in segs}
        assert len(undirected) == len(segs) == len(CYCLE) // 2  # up to 6.5 kg, never back down
        _offset, dashes = dashed.get_linestyle()[0]
        assert dashes is not None and len(dashes) == 2  # dashed, not solid
    assert any(ax.get_ylabel() == "dy [mm]" for ax in fig.axes)


def test_the_numbers_of_a_cycle_read_one_way(
    cycle: eodarm.Measurements,
    report: tuple[str, str],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    page, _ = report
    text = re.sub(r"data:[^\"]+", "", page)  # the page without its embedded images
    assert not re.search(r"\d(e|E)[−-]\d", text.replace("1e-300", "")), re.findall(
        r".{30}\d[eE][−-]\d.{10}", text
    )
    csv = tmp_path / "cycle.csv"
    cycle.to_csv(csv)
    assert main(["diagnose", str(csv), "--arm", str(EXAMPLE)]) == 0
    head = " ".join(capsys.readouterr().out.split()[:20])
    assert "payloads 1.5, 5, 6.5 and 0 kg" in head
