"""How numbers with errors read (eodarm.viz.format): the error to two significant digits,
the value to the same decimal place, the unit once, words for what is not a number."""

from __future__ import annotations

import math

import pytest

from eodarm.viz.format import (
    bounded_interval,
    channel_value,
    interval95,
    listing,
    parameter_name,
    plural,
    value,
    value_error,
)


@pytest.mark.parametrize(
    ("x", "err", "want"),
    [
        (12926.0, 3.0e3, "12900 ± 3000 N/mm"),  # issue 13's "12926 ± 3e+03"
        (0.151, 0.002, "0.1510 ± 0.0020 N/mm"),
        (580.4, 35.2, "580 ± 35 N/mm"),
        (-0.51, 0.013, "−0.510 ± 0.013 N/mm"),
        (4.3983e5, 3.3e6, "(0.4 ± 3.3)×10⁶ N/mm"),  # issue 13's undetermined body stiffness
        (2.3e-5, 4e-7, "(2.300 ± 0.040)×10⁻⁵ N/mm"),
    ],
)
def test_the_value_is_rounded_to_its_errors_two_digits(x: float, err: float, want: str) -> None:
    assert value_error(x, err, "N/mm") == want


def test_what_is_not_a_number_reads_as_words() -> None:
    assert value_error(1.5, math.inf, "mm") == "1.5 (± ?) mm"
    assert value_error(math.inf, 1.0, "N/mm") == "∞"
    assert value(math.nan, "mm") == "—"
    assert interval95(1.0, math.nan) == "—"


def test_the_95_interval_has_the_estimates_precision() -> None:
    assert interval95(580.4, 35.2) == "[511, 649]"
    assert interval95(12926.0, 3.0e3) == "[7000, 18800]"


def test_parameters_have_names_and_unknown_effects_still_read() -> None:
    assert parameter_name("actuator_compliance", "M1") == "actuator 1 body stiffness"
    assert parameter_name("joint_clearance", "O3") == "joint O3 clearance"
    assert parameter_name("base_compliance", "base") == "chassis tilt stiffness"
    assert parameter_name("actuator_friction", "M2") == "actuator friction at M2"


def test_an_interval_that_reaches_infinity_reads_as_a_lower_bound() -> None:
    # a stiffness whose θ = 1/k interval reaches 0: "at least", never a negative stiffness
    assert bounded_interval(19295.4, math.inf, "N/mm") == "≥ 19300 N/mm (up to rigid)"
    assert bounded_interval(0.0, 0.0312, "mm") == "[0, 0.0312] mm"
    assert bounded_interval(0.0, math.inf) == "—"  # nothing known


def test_a_practical_zero_reads_as_zero_not_as_rounding() -> None:
    """What a model without memory leaves at the return (1e-10 mm: the solvers' rounding)
    reads 0; below a micrometre of a micrometre it is below any sensor; above, a number."""
    assert channel_value(3e-10, "mm") == "0 mm"
    assert channel_value(-3e-10, "deg") == "0 deg"
    assert channel_value(4e-7, "mm") == "< 1e-6 mm"
    assert channel_value(-0.0425, "mm") == "−0.0425 mm"
    assert channel_value(0.00033, "mm") == "0.00033 mm"


def test_a_column_keeps_its_significant_figures() -> None:
    # "0.0003" beside "0.00033" reads as a less precise number: both to two figures
    assert value(0.0003, "mm", 2, zeros=True) == "0.00030 mm"
    assert value(0.00033, "mm", 2, zeros=True) == "0.00033 mm"
    assert value(6.0, digits=4, zeros=True) == "6"  # a count stays a count
    assert value(1.5, "kg") == "1.5 kg"  # an input keeps its own digits


def test_counts_and_lists_read_as_words() -> None:
    assert plural(1, "payload") == "1 payload"
    assert plural(4, "payload") == "4 payloads"
    assert plural(10044, "pose") == "10,044 poses"
    assert listing([1.5, 5.0, 6.5, 0.0], "kg") == "1.5, 5, 6.5 and 0 kg"
    assert listing([6.5], "kg") == "6.5 kg"
    assert listing([1.5, 5.0], "kg") == "1.5 and 5 kg"


def test_compensate_reads_what_it_leaves_as_zero_not_as_rounding(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """``compensate``'s ``left mm`` (the model's remaining miss, ~1e-11 mm) read "2e−11"
    beside "4.408": the one formatter makes it 0."""
    from pathlib import Path

    from eodarm.cli import main

    arm = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
    capsys.readouterr()
    code = main(["compensate", "--arm", str(arm), "--alpha", "90,10,0", "--mass", "5"])
    out = capsys.readouterr().out
    assert code == 0
    lines = out.splitlines()
    [head] = [i for i, line in enumerate(lines) if line.startswith("pose ")]
    assert lines[head].split()[-5:] == ["miss", "mm", "left", "mm", "status"]
    *_, miss, left, status = lines[head + 1].split()
    assert (left, status) == ("0", "ok")
    assert float(miss) > 1.0 and "e" not in miss
