"""Fuzzing the readers and the command line (issue 15): mutated arm files and measurement
files through ``eodarm compare`` and ``eodarm diagnose``.

The invariant, whatever the input: exit 0 with strict JSON on stdout (no NaN or Infinity)
and only notes on stderr, or exit 2 with exactly one line on stderr — never a traceback, an
uncaught exception or a panic of the core. The commands run in-process (through
``eodarm.cli.main``), so a crash is this test's own exception.

A fast profile runs with the suite (a few hundred cases); ``pytest -m fuzz`` runs the long one
(``FUZZ_CASES``, default 5000, split between the two commands), recorded in
docs/benchmarks.md.

The long profile also holds the adversarial checks of issue 23: measurement files without
``sigma_`` columns (the noise note must not come before a refusal: still exactly one line),
``fit --json`` besides ``compare`` and ``diagnose``, and random arms under heavy payloads
through ``eodarm.solve``, which must give every valid pose one answer (values, or NaN with a
status that is not ok, the same on both backends) and never raise.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import eodarm
from eodarm.analysis.synth import random_configs, synth
from eodarm.cli import main
from eodarm.data.datasets import example_arm
from eodarm.model.validity import MAX_LOAD_RISE_MM
from strategies import arm_and_poses

ARM_TEXT = example_arm().to_toml()


def _meas_text() -> str:
    arm = example_arm()
    alpha = random_configs(arm, 4, np.random.default_rng(0))
    meas = synth(arm, alpha, [1.5, 6.5], seed=0, repeats=2)
    buf = io.StringIO()
    meas.to_csv(buf)
    return buf.getvalue()


MEAS_TEXT = _meas_text()


def _without_sigma(text: str) -> str:
    """The file without its ``sigma_`` columns: the noise is then pooled from the repeats (or
    the defaults are used), and the command says so in a note."""
    rows = [line.split(",") for line in text.splitlines()]
    keep = [j for j, name in enumerate(rows[0]) if not name.startswith("sigma_")]
    return "\n".join(",".join(r[j] for j in keep if j < len(r)) for r in rows) + "\n"


MEAS_NO_SIGMA = _without_sigma(MEAS_TEXT)

#: Replacements for a number: what hostile or careless files hold.
WEIRD = [
    "1" + "0" * 309,
    "-1" + "0" * 400,
    "1e309",
    "-1e309",
    "1e200",
    "1e-300",
    "5e-324",
    "-0",
    "0",
    "nan",
    "NaN",
    "inf",
    "-Infinity",
    "",
    " ",
    "abc",
    "1,5",
    "0x10",
    "1_000",
    "²",
    "٣",
    '"1"',
    "[1, 2]",
    "true",
    "\t",
    "1e",
    "--1",
    "999999999999999999999",
    "3.0\n4.0",
    '"a\nb"',
]


@st.composite
def mutated(draw: st.DrawFn, text: str) -> str:
    """``text`` with a few mutations: tokens replaced, lines dropped, duplicated, cut, shuffled,
    bytes inserted, a BOM, deep nesting."""
    lines = text.splitlines()
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(
            st.sampled_from(
                ["token", "token", "token", "drop", "dup", "cut", "swap", "bytes", "bom", "nest"]
            )
        )
        if not lines:
            break
        i = draw(st.integers(0, len(lines) - 1))
        if kind == "token":
            parts = lines[i].replace(",", " , ").replace("=", " = ").split(" ")
            nums = [k for k, p in enumerate(parts) if p.strip(" []") not in ("", ",", "=")]
            if nums:
                k = draw(st.sampled_from(nums))
                parts[k] = draw(st.sampled_from(WEIRD))
                lines[i] = " ".join(parts).replace(" , ", ",").replace(" = ", " = ")
        elif kind == "drop":
            del lines[i]
        elif kind == "dup":
            lines.insert(i, lines[i])
        elif kind == "cut":
            lines[i] = lines[i][: draw(st.integers(0, max(len(lines[i]) - 1, 0)))]
        elif kind == "swap":
            j = draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
        elif kind == "bytes":
            junk = draw(st.text(min_size=1, max_size=8))
            lines[i] = lines[i][:3] + junk + lines[i][3:]
        elif kind == "bom":
            lines[0] = "\ufeff" + lines[0]
        elif kind == "nest":
            depth = draw(st.sampled_from([3, 50, 5000]))
            lines.insert(i, "x = " + "[" * depth + "]" * depth)
    return "\n".join(lines) + draw(st.sampled_from(["\n", ""]))


def _run(args: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(args)
    return code, out.getvalue(), err.getvalue()


def _strict(text: str) -> object:
    def refuse(token: str) -> None:
        raise AssertionError(f"JSON with {token}")

    return json.loads(text, parse_constant=refuse)


def check_invariant(tmp: Path, command: str, arm_text: str, meas_text: str) -> None:
    arm, meas = tmp / "arm.toml", tmp / "meas.csv"
    arm.write_bytes(arm_text.encode("utf-8", "surrogatepass"))
    meas.write_bytes(meas_text.encode("utf-8", "surrogatepass"))
    extra = {"diagnose": ["--max-set", "1"], "fit": ["--add", "joint_clearance@O3"]}.get(
        command, []
    )
    code, out, err = _run([command, str(meas), "--arm", str(arm), "--json", *extra])
    lines = [ln for ln in err.splitlines() if not ln.startswith("  ")]  # wrapped: continued
    if code == 0:
        assert isinstance(_strict(out), dict)
        assert all(line.startswith("eodarm: ") for line in lines), err
        assert "Traceback" not in err
    else:
        assert code == 2, (code, err)
        assert len(lines) == 1 and lines[0].startswith("eodarm: error: "), err
        assert out == "", out


FAST = settings(
    max_examples=120,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    derandomize=True,
)
LONG = settings(
    max_examples=int(os.environ.get("FUZZ_CASES", "5000")) // 2,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
inputs = st.one_of(
    st.tuples(mutated(ARM_TEXT), st.just(MEAS_TEXT)),
    st.tuples(st.just(ARM_TEXT), mutated(MEAS_TEXT)),
    st.tuples(mutated(ARM_TEXT), mutated(MEAS_TEXT)),
)
#: The long profile's inputs: the fast ones, and files without σ columns that fail late.
long_inputs = st.one_of(
    inputs,
    st.tuples(st.just(ARM_TEXT), mutated(MEAS_NO_SIGMA)),
    st.tuples(mutated(ARM_TEXT), st.just(MEAS_NO_SIGMA)),
)


@FAST
@given(case=inputs)
def test_compare_on_mutated_files_keeps_the_invariant(tmp_path: Path, case: tuple) -> None:
    check_invariant(tmp_path, "compare", *case)


@settings(FAST, max_examples=40)
@given(case=inputs)
def test_diagnose_on_mutated_files_keeps_the_invariant(tmp_path: Path, case: tuple) -> None:
    check_invariant(tmp_path, "diagnose", *case)


@pytest.mark.fuzz
@LONG
@given(case=long_inputs)
def test_long_fuzz_compare(tmp_path: Path, case: tuple) -> None:
    check_invariant(tmp_path, "compare", *case)


@pytest.mark.fuzz
@LONG
@given(case=long_inputs)
def test_long_fuzz_diagnose(tmp_path: Path, case: tuple) -> None:
    check_invariant(tmp_path, "diagnose", *case)


@pytest.mark.fuzz
@settings(LONG, max_examples=max(1, LONG.max_examples // 2))
@given(case=long_inputs)
def test_long_fuzz_fit(tmp_path: Path, case: tuple) -> None:
    check_invariant(tmp_path, "fit", *case)


@pytest.mark.fuzz
@settings(LONG, max_examples=max(1, LONG.max_examples // 5))
@given(case=arm_and_poses(max_links=5), heavy=st.floats(1.0, 200.0), data=st.data())
def test_long_fuzz_solve_gives_every_pose_one_answer(
    case: tuple, heavy: float, data: st.DataObject
) -> None:
    """Random arms, soft actuators now and then, payloads up to 200× the strategy's: every
    pose solved or NaN with a status that is not ok, on both backends alike; never an error
    (the poses are valid input); no ok pose whose load point rose."""
    arm, alpha, mass = case
    effects = []
    if data.draw(st.booleans(), label="soft"):
        k = data.draw(st.floats(5.0, 500.0), label="stiffness")
        effects = [eodarm.Effect("actuator_compliance", "M1", stiffness_n_per_mm=k)]
    out = eodarm.solve(arm, alpha, mass * heavy, effects)
    ref = eodarm.solve(arm, alpha, mass * heavy, effects, backend="numpy")
    failed = np.isnan(out["dy_mm"])
    np.testing.assert_array_equal(np.isnan(ref["dy_mm"]), failed)
    assert (out["status"][failed] != 0).all()
    assert np.isfinite(out["dalpha_deg"][~failed]).all()
    np.testing.assert_array_equal(out["status"][failed], ref["status"][failed])
    # an ok answer never has the load point rise (docs/model.md §7): with compliance only,
    # the loaded load point is the rigid arm at the loaded angles; 1e-6 mm of rounding
    ok = (out["status"] == 0) & (mass > 0)
    if ok.any():
        before = eodarm.forward(arm, alpha[ok])["O"][:, -1, 1]
        after = eodarm.forward(arm, alpha[ok] + out["dalpha_deg"][ok])["O"][:, -1, 1]
        assert (after - before <= MAX_LOAD_RISE_MM + 1e-6).all()
