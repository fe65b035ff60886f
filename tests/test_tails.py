"""The χ² and F tails and the bounded least-squares step that replace scipy on the commands'
start-up path equal scipy's (which the tests may import; the commands do not)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from eodarm.analysis.boxlsq import bounded_lstsq
from eodarm.analysis.consistency import chi2_p_value, lr_threshold
from eodarm.analysis.tails import betainc, chi2_isf, chi2_sf, f_isf, f_sf, gammaincc

special = pytest.importorskip("scipy.special")
optimize = pytest.importorskip("scipy.optimize")

#: Relative agreement asked of the tails: a p-value is a decision threshold and a printed
#: number, 1e-10 is far below either's resolution yet above the ~1e-11 rounding of the
#: continued fractions at 10⁶ degrees of freedom.
REL = 1e-10

DOF = [1, 2, 3, 5, 9.5, 10, 11, 30, 100, 102, 500, 7e4, 1e6]
RATIO = [1e-6, 0.01, 0.3, 0.9, 0.99, 1.0, 1.01, 1.1, 2.0, 5.0, 30.0, 1e3]


def _close(ours: float, theirs: float) -> bool:
    if theirs < 1e-300:  # both underflow: "p < 1e-300"
        return ours < 1e-290
    return abs(ours - theirs) <= REL * theirs


@pytest.mark.parametrize("k", DOF)
def test_chi2_tail_equals_scipy(k: float) -> None:
    for q in RATIO:
        x = k * q
        assert _close(chi2_sf(x, k), float(special.chdtrc(k, x))), (k, x)


@pytest.mark.parametrize("d1", [1, 2, 5, 19, 21, 100, 7e4])
def test_f_tail_equals_scipy(d1: float) -> None:
    for d2 in [1, 3, 10, 21, 50, 1000, 1e5, 1e6]:
        for f in [1e-4, 0.1, 0.5, 0.99, 1.0, 1.01, 1.5, 3.0, 10.0, 100.0, 1e4]:
            assert _close(f_sf(f, d1, d2), float(special.fdtrc(d1, d2, f))), (d1, d2, f)


@settings(max_examples=200, deadline=None)
@given(
    a=st.floats(0.05, 2e4),
    b=st.floats(0.05, 2e4),
    # subnormal x excluded: there scipy's xᵃ loses its digits (I_x(0.5, 2) at x = 5e-324:
    # scipy 2.89e-162, the exact x^a/(a·B(a, b)) = 3.33e-162, ours)
    x=st.floats(0.0, 1.0).filter(lambda v: v == 0.0 or v >= 1e-300),
)
def test_incomplete_beta_and_gamma_equal_scipy(a: float, b: float, x: float) -> None:
    theirs = float(special.betainc(a, b, x))
    if 1e-300 < theirs:
        assert betainc(a, b, x) == pytest.approx(theirs, rel=1e-9, abs=1e-300)
    q = float(special.gammaincc(a, x * 2 * a))
    if 1e-300 < q:
        assert gammaincc(a, x * 2 * a) == pytest.approx(q, rel=1e-9)


@pytest.mark.parametrize("p", [0.5, 0.05, 1e-3, 1e-6, 1e-12])
def test_quantiles_invert_the_tails_as_scipy(p: float) -> None:
    assert chi2_isf(p, 1) == pytest.approx(float(special.chdtri(1, p)), rel=REL)
    # scipy's fdtri takes the lower tail 1 − p, which has lost p's digits below ~1e-7
    for nu in (3, 12, 400) if p >= 1e-6 else ():
        assert f_isf(p, 1, nu) == pytest.approx(float(special.fdtri(1, nu, 1 - p)), rel=1e-9)
    # and the consistency module's tests use them
    assert lr_threshold(p) == pytest.approx(float(special.chdtri(1, p)), rel=REL)
    assert chi2_p_value(50.0, 40.0, 12.0) == pytest.approx(
        float(special.fdtrc(40.0, 12.0, 50.0 / 40.0)), rel=REL
    )


def test_tails_at_the_edges() -> None:
    assert chi2_sf(0.0, 3) == 1.0 and chi2_sf(math.inf, 3) == 0.0
    assert math.isnan(chi2_sf(math.nan, 3)) and math.isnan(f_sf(math.nan, 2, 3))
    assert f_sf(2.0, 3, math.inf) == pytest.approx(chi2_sf(6.0, 3), rel=1e-15)
    assert chi2_sf(1e5, 10) == 0.0  # underflow reads as "p < 1e-300", never as an error
    with pytest.raises(ValueError):
        chi2_isf(0.0, 1)


@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 8))
def test_bounded_least_squares_is_scipys_minimum(seed: int, n: int) -> None:
    """The same minimum of ‖A x − r‖² as scipy's BVLS, within the bounds, for columns of very
    different scales (a play in mm beside a compliance ~1e-9) and bounds of every kind."""
    rng = np.random.default_rng(seed)
    m = int(rng.integers(n, 40))
    a = rng.normal(size=(m, n)) * 10 ** rng.uniform(-4, 4, size=n)
    r = rng.normal(size=m) * 5
    lo = np.where(rng.random(n) < 0.7, -rng.random(n), -np.inf)
    hi = np.where(rng.random(n) < 0.5, rng.random(n), np.inf)
    x = bounded_lstsq(a, r, lo, hi)
    assert np.all(x >= lo) and np.all(x <= hi)
    norms = np.linalg.norm(a, axis=0)
    ref = optimize.lsq_linear(
        a / norms, r, bounds=(lo * norms, hi * norms), method="bvls", tol=1e-14
    ).x / np.linalg.norm(a, axis=0)
    ours, theirs = np.sum((a @ x - r) ** 2), np.sum((a @ ref - r) ** 2)
    # a convex minimum: ours is never above scipy's beyond rounding
    assert ours <= theirs * (1 + 1e-10) + 1e-20


def test_a_column_the_data_cannot_see_stays_put() -> None:
    a = np.array([[1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])
    x = bounded_lstsq(a, np.array([1.0, 2.0, 3.0]), np.array([0.0, 0.0]), np.array([5.0, 5.0]))
    assert x == pytest.approx([1.0, 0.0], abs=1e-12)
