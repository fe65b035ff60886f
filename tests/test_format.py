"""How numbers with errors read (eodarm.viz.format): the error to two significant digits,
the value to the same decimal place, the unit once, words for what is not a number."""

from __future__ import annotations

import math

import pytest

from eodarm.viz.format import bounded_interval, interval95, parameter_name, value, value_error


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
