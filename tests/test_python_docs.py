"""docs/python.md runs: its ```python blocks, in order, in one namespace, in an empty folder
(they write the files they read), as a user pastes them from a fresh clone. Each block asserts
what it shows; the test checks that the page shows every feature of the Python API and that
what it prints is what the page says it prints."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

PAGE = Path(__file__).resolve().parents[1] / "docs" / "python.md"


def blocks(text: str) -> list[str]:
    """The page's ```python blocks, in order."""
    return re.findall(r"^```python\n(.*?)^```$", text, flags=re.S | re.M)


def test_the_page_shows_every_feature_of_the_api() -> None:
    code = "\n".join(blocks(PAGE.read_text(encoding="utf-8")))
    for feature in (
        "eodarm.datasets.load(",
        "eodarm.read_measurements(",  # with the arm
        ", [1.5, 5.0, 6.5])",  # one pose under three payloads
        "fit.params[",
        "valuesdict()",
        "fit.chi2_per_dof",
        "fit.rms[",
        "fit.to_arm()",
        "uncertainty=True",
        "outputs=(",
        "eodarm.solve_sequence(",
        "with_effects(fit.effects)",
        "eodarm.diagnose(",
        "_repr_html_()",
    ):
        assert feature in code, feature


def test_the_pages_examples_run_and_print_what_it_says(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": "python_md"}
    printed = io.StringIO()
    for i, code in enumerate(blocks(PAGE.read_text(encoding="utf-8"))):
        with contextlib.redirect_stdout(printed):
            exec(compile(code, f"docs/python.md block {i + 1}", "exec"), namespace)
    out = printed.getvalue()
    page = PAGE.read_text(encoding="utf-8")
    # what the page shows in its output blocks and comments is what the examples print
    for line in (
        "<Measurements seed2022/measurements.csv: 15 states of a 3-link arm",
        "alpha_deg of shape (2, 3) and mass_kg of shape (3,) do not broadcast",
        "  joint_clearance@O2:clearance_mm         0.15046 ± 0.00053 mm",
        "<Diagnosis: missing: mount_compliance@M1 + joint_clearance@O2",
        "or in Python fit.to_arm()",
        "[[-0.871 -2.815 -7.344 -9.282 -7.344 -2.815 -0.871]]",
    ):
        assert line in out, line
        assert line in page, line
    assert (tmp_path / "seed" / "measurements.csv").is_file()
    assert (tmp_path / "fitted.toml").is_file()
